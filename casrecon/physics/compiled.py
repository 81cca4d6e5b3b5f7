"""CasADi functions (the fit's block functions, the simulator's steps) compiled to machine code
with the system C compiler, cached on disk.

CasADi evaluates an SX function in its virtual machine; the same function generated as C and
compiled runs several times faster, and the per-interval derivative function is most of a fit's
evaluation time. :func:`compiled` returns the compiled twin of a function (``casadi.external`` of
a shared library), building it once: the library is named by a SHA-256 hash of the function's
serialised expression, the CasADi version and the compiler command, and kept in the cache folder,
so later fits of the same model (the same vehicle, aero database and mesh rate; data are inputs,
not part of the expression) load it in milliseconds.

Settings (environment variables, read at each call)
    ``CASRECON_CODEGEN``: ``"on"`` (default) compiles when a C compiler exists; ``"off"`` keeps the
    interpreted functions.
    ``CASRECON_CACHE_DIR``: the cache folder (default ``$XDG_CACHE_HOME/casrecon/codegen``, else
    ``~/.cache/casrecon/codegen``).
    ``CC``: the compiler (default ``cc``, then ``gcc``, then ``clang``).

Whatever fails (no compiler, a compiler error, an unwritable cache) falls back to the interpreted
function with one logged warning: compilation changes the speed, never the result.

A fit's block functions are built *in the background* (``compiled(f, in_background=True)``,
what :meth:`casrecon.estimation.engine.blocks.BlockSet.mapped` asks for): a fit that does not find
a library evaluates the interpreted function while a detached process builds the library, which
later fits, in this process (a refit) or another, then load. No fit waits for a compiler: the
first fit of a new vehicle or mesh rate waited 18 s for its derivatives' (issue 49), and the exact
Hessian's -O1 build takes longer than a fit (ees-drop-1's interval exact Hessian, 165,000
instructions: 52 s, and 33 s for its GPS blocks'). A mark file beside the library keeps processes
from building it twice; a build that fails leaves a note (``.failed``) that stops retries for
FAILED_RETRY_S and is repeated in one warning per process.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca

LOG = logging.getLogger(__name__)

#: Optimisation flag. -O1 compiles the ~40,000-instruction interval derivative function in a few
#: seconds and runs it about 4x faster than the interpreter; -O2 gains little more and compiles
#: several times longer (see benchmarks/fit_speed.py).
OPT_FLAG = "-O1"

#: A background build is stopped after this long (s), and a mark older than this is taken as that
#: of a build that died: another build may start.
STALE_BUILD_S = 1800.0
#: A background build that failed leaves a note (``library.failed``, the compiler's last words);
#: for this long (s) after it no build of that library is started again (each would take minutes
#: of CPU to fail the same way), and the fits that want it say so once per process.
FAILED_RETRY_S = 86400.0
#: What the detached process of a background build runs: compile (the command in argv), move the
#: library into place or, if that fails, write the failure note; remove its temporary folder and
#: the mark, whatever happens.
_BACKGROUND_SCRIPT = """
import os, shutil, subprocess, sys
out, library, mark, folder, timeout, failed = sys.argv[1:7]

def note(text):
    lines = str(text).strip().splitlines()
    try:
        with open(failed + ".tmp", "w") as f:
            f.write((lines[-1] if lines else "no reason given") + "\\n")
        os.replace(failed + ".tmp", failed)
    except OSError:
        pass

try:
    subprocess.run(sys.argv[7:], check=True, capture_output=True, text=True, timeout=float(timeout))
    os.replace(out, library)
except subprocess.CalledProcessError as err:
    note(err.stderr or err)
except Exception as err:  # a timeout, a compiler that cannot start, a library that cannot be moved
    note(err if str(err) else type(err).__name__)
finally:
    shutil.rmtree(folder, ignore_errors=True)
    try:
        os.unlink(mark)
    except OSError:
        pass
"""

_loaded: dict[str, ca.Function] = {}
_warned: set[str] = set()
_background: list[subprocess.Popen] = []


def reset() -> None:
    """Forget the libraries loaded and the warnings given in this process (as a new process starts)."""
    _loaded.clear()
    _warned.clear()


def wait_for_background_builds(timeout_s: float | None = None) -> None:
    """Wait until the background builds this process started have ended (e.g. before timing fits
    whose libraries they make); ``timeout_s``: at most this long in all."""
    end = None if timeout_s is None else time.monotonic() + timeout_s
    while _background:
        left = None if end is None else max(end - time.monotonic(), 0.0)
        try:
            _background[0].wait(left)
        except subprocess.TimeoutExpired:
            return
        _background.pop(0)


def cache_dir() -> Path:
    """The folder compiled libraries are kept in (see the module docstring)."""
    env = os.environ.get("CASRECON_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "casrecon" / "codegen"


def compiler() -> str | None:
    """Path of the C compiler to use, or None when there is none."""
    wanted = os.environ.get("CC")
    for name in ([wanted] if wanted else []) + ["cc", "gcc", "clang"]:
        path = shutil.which(name)
        if path:
            return path
    return None


def enabled() -> bool:
    """Whether block functions are compiled (``CASRECON_CODEGEN`` is not ``off``)."""
    return os.environ.get("CASRECON_CODEGEN", "on").strip().lower() not in ("off", "0", "no", "false")


def library_key(function: ca.Function, cc: str) -> str:
    """Hash naming the library of ``function`` built by compiler ``cc``."""
    h = hashlib.sha256()
    for part in (ca.__version__, cc, OPT_FLAG, function.name(), function.serialize()):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:40]


def compiled(function: ca.Function, in_background: bool = False) -> ca.Function:
    """The compiled twin of ``function`` (same name, inputs and outputs), or ``function`` itself
    when compilation is off or impossible. ``in_background``: when the library is not built yet,
    start its build in a detached process and return ``function`` itself (see the module
    docstring)."""
    cc = compiler() if enabled() else None
    if cc is None or (in_background and cc in _warned):
        return function
    key = library_key(function, cc)
    if key in _loaded:
        return _loaded[key]
    library = cache_dir() / f"{function.name()}-{key}.so"
    try:
        if not library.exists():
            if in_background:
                start_background_build(function, cc, library)
                return function
            build_library(function, cc, library)
        twin = ca.external(function.name(), str(library))
    except (OSError, RuntimeError, subprocess.SubprocessError) as err:
        if cc not in _warned:
            _warned.add(cc)
            LOG.warning("casrecon: compiling block functions with %s failed (%s); using the interpreted ones",
                        cc, str(err).strip().splitlines()[-1] if str(err).strip() else type(err).__name__)
        return function
    _loaded[key] = twin
    return twin


def build_library(function: ca.Function, cc: str, library: Path) -> None:
    """Generate ``function`` as C and compile it into ``library``, atomically (a temporary file
    renamed into place, so concurrent builders never see a half-written library)."""
    library.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=".build-", dir=library.parent) as tmp:
        command, out = _generated(function, cc, Path(tmp), library.name)
        subprocess.run(command, check=True, capture_output=True, text=True, timeout=600)
        os.replace(out, library)
    LOG.debug("compiled %s -> %s", function.name(), library)


def start_background_build(function: ca.Function, cc: str, library: Path) -> None:
    """Generate ``function`` as C here and compile it into ``library`` in a detached process (it
    outlives this one), unless another build of it is under way: its mark file
    (``library.building``) exists and is younger than STALE_BUILD_S. The library appears
    atomically, as with :func:`build_library`."""
    library.parent.mkdir(parents=True, exist_ok=True)
    mark = library.with_suffix(".building")
    if earlier_failure(function, library):
        return
    try:
        if time.time() - mark.stat().st_mtime < STALE_BUILD_S:
            return
        mark.unlink(missing_ok=True)  # a build that died
    except FileNotFoundError:
        pass
    try:
        os.close(os.open(mark, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:  # another process has just started it
        return
    folder = Path(tempfile.mkdtemp(prefix=".build-", dir=library.parent))
    try:
        command, out = _generated(function, cc, folder, library.name)
        _background.append(subprocess.Popen(
            [sys.executable, "-c", _BACKGROUND_SCRIPT, str(out), str(library), str(mark), str(folder),
             str(STALE_BUILD_S), str(library.with_suffix(".failed")), *command],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        mark.unlink(missing_ok=True)
        raise
    LOG.debug("building %s in the background -> %s", function.name(), library)


def earlier_failure(function: ca.Function, library: Path) -> bool:
    """Whether a background build of ``library`` failed less than FAILED_RETRY_S ago (its note
    ``library.failed`` says why; the first time in this process a warning repeats it). An older
    note is removed: the build may be tried again."""
    note = library.with_suffix(".failed")
    try:
        age_s = time.time() - note.stat().st_mtime
        reason = note.read_text(errors="replace").strip() or "no reason given"
    except OSError:
        return False
    if age_s >= FAILED_RETRY_S:
        note.unlink(missing_ok=True)
        return False
    if str(note) not in _warned:
        _warned.add(str(note))
        LOG.warning("casrecon: the background build of %s failed %.0f min ago (%s); its interpreted function is "
                    "used (slower, same numbers); remove %s to try again", function.name(), age_s / 60.0, reason, note)
    return True


def _generated(function: ca.Function, cc: str, folder: Path, library_name: str) -> tuple[list[str], Path]:
    """``function`` generated as C in ``folder``; (the compile command, the library it writes there)."""
    source = f"{function.name()}.c"
    generator = ca.CodeGenerator(source, {"with_header": False})
    generator.add(function)
    generator.generate(str(folder) + os.sep)
    out = folder / library_name
    return [cc, "-shared", "-fPIC", OPT_FLAG, "-o", str(out), str(folder / source)], out
