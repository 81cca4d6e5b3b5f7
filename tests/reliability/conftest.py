"""Helpers of the reliability suite (issue 17): bad inputs and faults end in one line and a documented
exit status, never a traceback; no input is modified; no earlier result is lost; no temporary folder
is left behind.

Test modules of this package import the helpers relatively (the package has an ``__init__.py`` so
that this conftest does not shadow ``tests/conftest.py``, which other test modules import as
``conftest``)::

    from .conftest import run_cli, tree_checksums, leftover_temp_folders, assert_clean_failure

- :func:`run_cli` runs ``python -m casrecon ARGS`` in a subprocess (this checkout first on the path);
- :func:`call_cli` runs ``casrecon.cli.main`` in this process instead (fast; for failures before any work);
- :func:`start_cli` starts it without waiting, :func:`wait_for_handlers` until its command runs (to signal it);
- :func:`tree_checksums` maps every file under a folder to its SHA-256 (compare before and after);
- :func:`leftover_temp_folders` lists ``.NAME.tmp-*`` / ``.NAME.old-*`` / probe folders under a folder;
- :func:`assert_clean_failure` checks the exit status, no traceback, and one ``casrecon`` line;
- :func:`make_results_folder` writes a small casrecon results folder by hand (an "earlier result");
- fixtures ``drop_problem`` (a copy of ees-drop-1 with vehicles/ and aero/ beside it) and
  ``realdata_problem`` (a copy of realdata-fs1-byron), each in its own tmp folder.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PROBLEMS = REPO / "problems"
TRACEBACK = "Traceback (most recent call last)"
#: Names of the temporary, backup and probe folders casrecon makes beside a results folder.
TEMP_PATTERN = re.compile(r"^\..+\.(tmp|old)-|^\.casrecon-probe-")


def cli_env(extra: dict[str, str] | None = None) -> dict[str, str]:
    """The environment of a CLI subprocess: this checkout first on ``PYTHONPATH``, no ``CASRECON_DEBUG``."""
    env = dict(os.environ)
    env.pop("CASRECON_DEBUG", None)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), env.get("PYTHONPATH", "")) if p)
    env.setdefault("MPLBACKEND", "Agg")
    env.update(extra or {})
    return env


def run_cli(*args, cwd: str | Path | None = None, timeout: float = 120.0,
            env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """Run ``python -m casrecon *args`` (arguments converted with ``str``) and wait; text output captured."""
    return subprocess.run([sys.executable, "-m", "casrecon", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, env=cli_env(env))


def start_cli(*args, cwd: str | Path | None = None, env: dict[str, str] | None = None) -> subprocess.Popen:
    """Start ``python -m casrecon *args`` without waiting (stdout and stderr piped, text)."""
    return subprocess.Popen([sys.executable, "-m", "casrecon", *map(str, args)], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=cli_env(env))


def call_cli(capsys, *args) -> subprocess.CompletedProcess:
    """Run ``casrecon.cli.main(args)`` in this process (no interpreter start: for the many cases that fail
    before any work); stdout and stderr from ``capsys``, returned like :func:`run_cli`'s result."""
    from casrecon.cli import main

    capsys.readouterr()
    argv = [str(a) for a in args]
    try:
        code = main(argv)
    except SystemExit as stop:  # argparse: usage errors
        code = stop.code if isinstance(stop.code, int) else 1
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(argv, code, out, err)


def wait_for_handlers(proc: subprocess.Popen, timeout: float = 60.0) -> bool:
    """Wait until ``proc`` has a SIGTERM handler installed (casrecon's command is running: Linux
    ``/proc/PID/status`` ``SigCgt``); False if it ended or the timeout passed first."""
    deadline = time.monotonic() + timeout
    status = Path(f"/proc/{proc.pid}/status")
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            caught = next(ln for ln in status.read_text().splitlines() if ln.startswith("SigCgt:"))
        except (OSError, StopIteration):
            return False
        if int(caught.split()[1], 16) & (1 << (signal.SIGTERM - 1)):
            return True
        time.sleep(0.05)
    return False


def tree_checksums(path: str | Path) -> dict[str, str]:
    """SHA-256 of every file under ``path`` (or of ``path`` itself when it is a file), by relative
    POSIX path; symbolic links as ``link:TARGET``; folders as ``dir`` (so an emptied folder differs)."""
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return {}
    items = [path] if not path.is_dir() else sorted(path.rglob("*"))
    out = {}
    for p in items:
        rel = p.name if p == path else p.relative_to(path).as_posix()
        if p.is_symlink():
            out[rel] = f"link:{os.readlink(p)}"
        elif p.is_dir():
            out[rel] = "dir"
        else:
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def leftover_temp_folders(path: str | Path) -> list[Path]:
    """Temporary, backup or probe folders (``.NAME.tmp-*``, ``.NAME.old-*``, ``.casrecon-probe-*``)
    anywhere under ``path``."""
    path = Path(path)
    return sorted(p for p in path.rglob(".*") if TEMP_PATTERN.match(p.name)) if path.is_dir() else []


def assert_no_traceback(proc: subprocess.CompletedProcess) -> None:
    """Neither output holds a Python traceback."""
    assert TRACEBACK not in proc.stderr and TRACEBACK not in (proc.stdout or ""), proc.stderr[-3000:]


#: A progress line of a redirected log (``montecarlo: 250/1000 cases, 12 s, about 36 s left``).
PROGRESS = re.compile(r"^[\w -]+: \d+/\d+ \w+, \d+ s")


def error_lines(proc: subprocess.CompletedProcess) -> list[str]:
    """The non-empty stderr lines; progress bars and warnings of libraries excluded."""
    lines = [ln.strip() for ln in re.split(r"[\r\n]+", proc.stderr)]
    return [ln for ln in lines if ln and not PROGRESS.search(ln) and "Warning" not in ln
            and not ln.startswith("warnings.warn")]


def assert_clean_failure(proc: subprocess.CompletedProcess, code: int, *fragments: str,
                         one_line: bool = True) -> str:
    """Exit status ``code``, no traceback, and (with ``one_line``) exactly one error line starting
    with ``casrecon`` that contains every fragment (case-insensitive). Returns that line."""
    assert_no_traceback(proc)
    assert proc.returncode == code, f"exit {proc.returncode}, expected {code}; stderr:\n{proc.stderr[-3000:]}"
    lines = error_lines(proc)
    assert lines, "no error line on stderr"
    if one_line:
        assert len(lines) == 1, f"expected one line, got {len(lines)}:\n" + "\n".join(lines)
    line = lines[-1]
    assert line.startswith("casrecon"), line
    for fragment in fragments:
        assert fragment.lower() in line.lower(), f"{fragment!r} not in {line!r}"
    return line


def make_results_folder(path: str | Path, kind: str = "fit", marker: bool = True) -> dict[str, str]:
    """Write a small results folder by hand (``summary.json``, ``report.txt`` and, with ``marker``,
    ``.casrecon-results.json``); returns its :func:`tree_checksums`."""
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    (path / "summary.json").write_text(json.dumps({"problem": "earlier", "converged": True}) + "\n")
    (path / "report.txt").write_text("an earlier result\n")
    if marker:
        (path / ".casrecon-results.json").write_text(json.dumps({"written_by": "casrecon", "kind": kind}) + "\n")
    return tree_checksums(path)


@pytest.fixture
def drop_problem(tmp_path) -> Path:
    """A copy of problems/ees-drop-1 (vehicles/ and aero/ beside it): the problem folder."""
    root = tmp_path / "problems"
    root.mkdir()
    for name in ("ees-drop-1", "vehicles", "aero"):
        shutil.copytree(PROBLEMS / name, root / name)
    return root / "ees-drop-1"


@pytest.fixture
def realdata_problem(tmp_path) -> Path:
    """A copy of problems/realdata-fs1-byron (a real FlySight track, a point-mass problem): the folder."""
    folder = tmp_path / "realdata-fs1-byron"
    shutil.copytree(PROBLEMS / "realdata-fs1-byron", folder)
    return folder


@pytest.fixture(scope="session")
def fitted_drop_folder(tmp_path_factory) -> Path:
    """The results folder of ``casrecon fit problems/ees-drop-1 --no-figures``, fitted once per session
    (about 20 s); copy it before changing it."""
    from casrecon.cli import main

    out = tmp_path_factory.mktemp("fitted") / "ees-drop-1"
    assert main(["fit", str(PROBLEMS / "ees-drop-1"), "--out", str(out), "--no-figures", "--quiet"]) == 0
    return out


def edit_text(path: Path, old: str, new: str) -> None:
    """Replace the first ``old`` in the text file ``path`` by ``new`` (asserting it is there)."""
    text = path.read_text()
    assert old in text, f"{old!r} not in {path}"
    path.write_text(text.replace(old, new, 1))
