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
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

LOG = logging.getLogger(__name__)

#: Optimisation flag. -O1 compiles the ~40,000-instruction interval derivative function in a few
#: seconds and runs it about 4x faster than the interpreter; -O2 gains little more and compiles
#: several times longer (see benchmarks/fit_speed.py).
OPT_FLAG = "-O1"

_loaded: dict[str, ca.Function] = {}
_warned: set[str] = set()


def reset() -> None:
    """Forget the libraries loaded and the warnings given in this process (as a new process starts)."""
    _loaded.clear()
    _warned.clear()


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


def compiled(function: ca.Function) -> ca.Function:
    """The compiled twin of ``function`` (same name, inputs and outputs), or ``function`` itself
    when compilation is off or impossible."""
    cc = compiler() if enabled() else None
    if cc is None:
        return function
    key = library_key(function, cc)
    if key in _loaded:
        return _loaded[key]
    library = cache_dir() / f"{function.name()}-{key}.so"
    try:
        if not library.exists():
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
        source = f"{function.name()}.c"
        generator = ca.CodeGenerator(source, {"with_header": False})
        generator.add(function)
        generator.generate(tmp + os.sep)
        out = Path(tmp) / library.name
        subprocess.run([cc, "-shared", "-fPIC", OPT_FLAG, "-o", str(out), str(Path(tmp) / source)],
                       check=True, capture_output=True, text=True, timeout=600)
        os.replace(out, library)
    LOG.info("compiled %s -> %s", function.name(), library)
