"""Compiled block functions (casrecon.physics.compiled): same numbers as the interpreter,
built once and then loaded from the disk cache, and an interpreted fallback whenever compiling is
off or fails."""

from __future__ import annotations

import logging
import os
import shutil
import threading

import casadi as ca
import numpy as np
import pytest

from casrecon.physics import compiled as cg

pytestmark = pytest.mark.skipif(cg.compiler() is None, reason="no C compiler on this machine")


def block_function(name: str) -> ca.Function:
    """A small nonlinear block function with several outputs (like a block's derivatives)."""
    x = ca.SX.sym("x", 6)
    d = ca.SX.sym("d", 3)
    r = ca.vertcat(ca.sin(x[0]) * x[1] - d[0], ca.exp(0.1 * x[2]) + x[3] ** 3 - d[1],
                   ca.atan2(x[4], 1 + x[5] ** 2) - d[2])
    j = ca.jacobian(r, x)
    return ca.Function(name, [x, d], [ca.mtimes(j.T, r), ca.densify(ca.vec(j)), r])


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("CASRECON_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("CASRECON_CODEGEN", raising=False)
    return tmp_path / "cache"


def evaluate(f: ca.Function, n: int = 50) -> list[np.ndarray]:
    rng = np.random.default_rng(1)
    mapped = f.map(n, "thread", 2)
    return [np.asarray(o) for o in mapped(rng.normal(size=(6, n)), rng.normal(size=(3, n)))]


def test_compiled_function_gives_the_interpreters_numbers(cache):
    f = block_function("blk_same")
    twin = cg.compiled(f)
    assert twin is not f and twin.name() == f.name()
    assert [p.name for p in cache.iterdir()] == [f"blk_same-{cg.library_key(f, cg.compiler())}.so"]
    for a, b in zip(evaluate(f), evaluate(twin)):
        np.testing.assert_allclose(b, a, rtol=1e-13, atol=1e-15)


def test_second_use_loads_the_cached_library_without_compiling(cache, monkeypatch):
    f = block_function("blk_cached")
    cg.compiled(f)
    library = next(cache.iterdir())
    stamp = library.stat().st_mtime_ns
    cg.reset()  # as a new process would start

    def no_compiler(*args, **kwargs):
        raise AssertionError("compiled again although the library is cached")

    monkeypatch.setattr(cg, "build_library", no_compiler)
    again = cg.compiled(block_function("blk_cached"))  # a new but identical expression
    assert library.stat().st_mtime_ns == stamp and len(list(cache.iterdir())) == 1
    for a, b in zip(evaluate(f), evaluate(again)):
        np.testing.assert_allclose(b, a, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("in_background", [False, True])
def test_compile_messages_are_debug_not_info(cache, caplog, in_background):
    f = block_function(f"blk_quiet_{int(in_background)}")
    cg.reset()
    with caplog.at_level(logging.DEBUG, logger=cg.LOG.name):
        cg.compiled(f, in_background=in_background)
        cg.wait_for_background_builds(120.0)
    about_cache = [r for r in caplog.records if str(cache) in r.getMessage()]
    assert about_cache and all(r.levelno == logging.DEBUG for r in about_cache)  # said, but not at INFO


def test_a_different_expression_gets_its_own_library(cache):
    cg.compiled(block_function("blk_a"))
    x = ca.SX.sym("x", 6)
    d = ca.SX.sym("d", 3)
    other = ca.Function("blk_a", [x, d], [ca.sumsqr(x) * d[0]])
    cg.compiled(other)
    assert len(list(cache.iterdir())) == 2


def test_codegen_off_keeps_the_interpreted_function(cache, monkeypatch):
    monkeypatch.setenv("CASRECON_CODEGEN", "off")
    f = block_function("blk_off")
    assert cg.compiled(f) is f and not cache.exists()


@pytest.fixture
def broken_compiler(tmp_path, monkeypatch):
    """``CC`` set to a compiler that always fails, saying so on stderr."""
    broken = tmp_path / "bin" / "broken-cc"
    broken.parent.mkdir()
    broken.write_text("#!/bin/sh\necho 'broken-cc: cannot compile' >&2\nexit 1\n")
    broken.chmod(0o755)
    monkeypatch.setenv("CC", str(broken))
    cg.reset()
    return broken


def test_a_failing_compiler_falls_back_with_one_warning(cache, broken_compiler, caplog):
    with caplog.at_level(logging.WARNING, logger=cg.LOG.name):
        f = block_function("blk_broken")
        assert cg.compiled(f) is f
        assert cg.compiled(block_function("blk_broken2")).name() == "blk_broken2"
    warnings = [r for r in caplog.records if "compiling block functions" in r.getMessage()]
    assert len(warnings) == 1 and "interpreted" in warnings[0].getMessage()
    assert not cache.exists() or not any(p.suffix == ".so" for p in cache.rglob("*"))


def test_concurrent_builders_leave_one_complete_library(cache):
    f = block_function("blk_race")
    out: list = []

    def build():
        out.append(cg.compiled(block_function("blk_race")))

    cg.reset()
    threads = [threading.Thread(target=build) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert [p.suffix for p in cache.iterdir()] == [".so"]
    for twin in out:
        for a, b in zip(evaluate(f), evaluate(twin)):
            np.testing.assert_allclose(b, a, rtol=1e-13, atol=1e-15)


def test_an_unwritable_cache_falls_back(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("CASRECON_CACHE_DIR", str(blocker / "cache"))
    monkeypatch.delenv("CASRECON_CODEGEN", raising=False)
    f = block_function("blk_unwritable")
    assert cg.compiled(f) is f
    shutil.rmtree(tmp_path / "cache", ignore_errors=True)


def test_a_background_build_returns_the_interpreted_function_and_leaves_the_library(cache):
    f = block_function("blk_background")
    cg.reset()
    assert cg.compiled(f, in_background=True) is f  # nothing built yet: the interpreter meanwhile
    library = cache / f"blk_background-{cg.library_key(f, cg.compiler())}.so"
    assert library.with_suffix(".building").exists() or library.exists()
    assert cg.compiled(block_function("blk_background"), in_background=True).name() == "blk_background"
    cg.wait_for_background_builds(120.0)
    assert library.exists() and not library.with_suffix(".building").exists()
    assert [p.name for p in cache.iterdir()] == [library.name]  # its temporary folder removed
    twin = cg.compiled(block_function("blk_background"), in_background=True)
    assert twin.class_name() == "External"
    for a, b in zip(evaluate(f), evaluate(twin)):
        np.testing.assert_allclose(b, a, rtol=1e-13, atol=1e-15)


def test_a_build_under_way_is_not_started_again_and_a_stale_mark_is(cache, monkeypatch):
    f = block_function("blk_marked")
    cg.reset()
    library = cache / f"blk_marked-{cg.library_key(f, cg.compiler())}.so"
    cache.mkdir()
    mark = library.with_suffix(".building")
    mark.touch()  # another process is building it
    assert cg.compiled(f, in_background=True) is f
    cg.wait_for_background_builds(5.0)
    assert mark.exists() and not library.exists()  # no second build was started
    old = mark.stat().st_mtime - cg.STALE_BUILD_S - 1.0
    os.utime(mark, (old, old))  # that build died long ago
    assert cg.compiled(f, in_background=True) is f
    cg.wait_for_background_builds(120.0)
    assert library.exists() and not mark.exists()


def test_a_failing_background_build_leaves_a_note_and_is_not_retried_at_once(cache, broken_compiler, caplog,
                                                                             monkeypatch):
    """A background build that fails leaves no library and no mark but a note with the compiler's
    words; the next fits use the interpreted function, say why once, and start no build until the
    note is FAILED_RETRY_S old."""
    f = block_function("blk_background_broken")
    assert cg.compiled(f, in_background=True) is f
    cg.wait_for_background_builds(60.0)
    notes = list(cache.iterdir())
    assert [p.suffix for p in notes] == [".failed"]
    assert "broken-cc: cannot compile" in notes[0].read_text()
    started = []

    class Started:
        def __init__(self, *args, **kwargs):
            started.append(args)

        def wait(self, timeout=None):
            return 0

    monkeypatch.setattr(cg.subprocess, "Popen", Started)
    with caplog.at_level(logging.WARNING, logger=cg.LOG.name):
        cg.reset()
        for _ in range(2):
            assert cg.compiled(block_function("blk_background_broken"), in_background=True).name() == \
                "blk_background_broken"
    warnings = [r.getMessage() for r in caplog.records if "background build" in r.getMessage()]
    assert len(warnings) == 1 and "broken-cc: cannot compile" in warnings[0] and str(notes[0]) in warnings[0]
    assert not started
    old = notes[0].stat().st_mtime - cg.FAILED_RETRY_S - 1.0
    os.utime(notes[0], (old, old))  # a day later: tried again
    cg.compiled(block_function("blk_background_broken"), in_background=True)
    assert len(started) == 1 and not notes[0].exists()
    cg.wait_for_background_builds(1.0)  # forget the stand-in build


def test_a_background_build_past_its_time_leaves_a_note_saying_so(cache, tmp_path, monkeypatch):
    slow = tmp_path / "bin" / "slow-cc"
    slow.parent.mkdir()
    slow.write_text("#!/bin/sh\nsleep 20\n")
    slow.chmod(0o755)
    monkeypatch.setenv("CC", str(slow))
    monkeypatch.setattr(cg, "STALE_BUILD_S", 0.5)
    cg.reset()
    f = block_function("blk_background_slow")
    assert cg.compiled(f, in_background=True) is f
    cg.wait_for_background_builds(60.0)
    notes = list(cache.iterdir())
    assert [p.suffix for p in notes] == [".failed"] and "timed out" in notes[0].read_text()


def test_a_fits_block_functions_never_wait_for_a_compiler(cache, monkeypatch):
    """The first fit of a new vehicle or mesh evaluates its derivatives interpreted while their
    library is built in the background (issue 49: a first fit waited 18 s for its compiles); a
    later fit's block set loads the library."""
    from casrecon.estimation.engine import blocks

    monkeypatch.setattr(blocks, "COMPILE_MIN_WORK", 1)
    cg.reset()
    x, d = ca.SX.sym("x", 6), ca.SX.sym("d", 3)
    residual = ca.vertcat(ca.sin(x[0]) * x[1] - d[0], ca.exp(0.1 * x[2]) + x[3] ** 3 - d[1], x[4] * x[5] - d[2])
    kind = blocks.BlockKind("blk_fit", x, [d], residual, None)
    first = blocks.BlockSet(kind, np.arange(6)[None, :])
    assert first.derivs is kind.derivatives and first.value_function is kind.values  # interpreted, no wait
    library = cache / f"blk_fit_derivatives-{cg.library_key(kind.derivatives, cg.compiler())}.so"
    assert library.with_suffix(".building").exists() or library.exists()
    cg.wait_for_background_builds(120.0)
    later = blocks.BlockSet(kind, np.arange(6)[None, :])
    assert later.derivs.class_name() == "External"
