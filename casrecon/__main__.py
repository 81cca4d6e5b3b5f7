"""``python -m casrecon``: the ``casrecon`` command."""

import sys

from casrecon.cli import main

sys.exit(main())
