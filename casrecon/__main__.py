"""``python -m casrecon``: the ``casrecon`` command."""

from casrecon.cli import run

run()
