"""Conventions shared by every ``casrecon`` command: ``--version``, defaults in ``--help``, and
``--quiet`` / ``--verbose`` wired to :mod:`logging`.

The library logs through ``logging.getLogger(__name__)`` (loggers under ``casrecon``); the command
line configures the ``casrecon`` logger once, to stderr: WARNING with ``--quiet``, INFO by default
(progress: a fit's Ipopt iterations, a profile's grid points), DEBUG with ``--verbose``.
"""

from __future__ import annotations

import argparse
import logging
import sys

#: The logger every casrecon module logs under (``logging.getLogger(__name__)``).
LOGGER = "casrecon"


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Shows each option's default (unless None, False, empty or already named in
    its help) and keeps the
    line breaks of descriptions and epilogs."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if action.default is None or action.default is False or action.default == [] or "default" in text:
            return text
        return super()._get_help_string(action)


def version_text() -> str:
    """``casrecon <version>``, from ``casrecon.__version__``."""
    import casrecon

    return f"casrecon {casrecon.__version__}"


def add_verbosity_arguments(p: argparse.ArgumentParser, quiet_help: str = "print only results and errors") -> None:
    """Add the mutually exclusive ``--quiet`` and ``--verbose`` to the command parser ``p``."""
    group = p.add_mutually_exclusive_group()
    group.add_argument("--quiet", action="store_true", help=quiet_help + " (log level WARNING)")
    group.add_argument("--verbose", action="store_true",
                       help="also debug messages and, for fits, Ipopt's own iteration output (log level DEBUG)")


def log_level(args: argparse.Namespace) -> int:
    """WARNING with ``--quiet``, DEBUG with ``--verbose``, else INFO."""
    if getattr(args, "quiet", False):
        return logging.WARNING
    return logging.DEBUG if getattr(args, "verbose", False) else logging.INFO


def configure_logging(level: int, stream=None) -> logging.Logger:
    """Send the ``casrecon`` logger's messages of ``level`` and above to ``stream`` (default: the
    current ``sys.stderr``), one plain line each; replaces the handler a previous call installed.
    Records still propagate (the root logger has no handler unless an application adds one)."""
    logger = logging.getLogger(LOGGER)
    for handler in [h for h in logger.handlers if getattr(h, "casrecon_cli", False)]:
        logger.removeHandler(handler)
    from casrecon.progress import note_line

    handler = logging.StreamHandler(stream) if stream is not None else StderrHandler()
    handler.casrecon_cli = True
    handler.addFilter(lambda record: note_line() or True)  # a line written: no heartbeat due (casrecon.progress)
    handler.setFormatter(logging.Formatter("%(message)s"))
    logger.addHandler(handler)
    logger.setLevel(level)
    return logger


class StderrHandler(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is at the time of each message (as ``logging.lastResort``)."""

    def __init__(self) -> None:
        logging.Handler.__init__(self)

    @property
    def stream(self):
        return sys.stderr
