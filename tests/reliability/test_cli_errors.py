"""Issue 17, tracebacks: every command run with broken arguments ends in one ``casrecon`` line and a
documented exit status (2 bad input or arguments, 1 unexpected error), never a traceback; nothing is
written and no input is touched.

Most cases run ``casrecon.cli.main`` in this process (:func:`call_cli`, they fail before any work);
:func:`test_through_the_interpreter` runs a representative set through ``python -m casrecon``.
"""

from __future__ import annotations

import errno
import socket

import pytest

from casrecon.cli_guard import describe

from .conftest import (
    PROBLEMS,
    TRACEBACK,
    assert_clean_failure,
    assert_no_traceback,
    call_cli,
    leftover_temp_folders,
    run_cli,
    tree_checksums,
)

DROP = PROBLEMS / "ees-drop-1"
MISSING = PROBLEMS / "no-such-problem"


def closed_port() -> int:
    """A local TCP port nobody listens on (bound, then released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


#: Broken invocations (``{OUT}`` is a fresh results folder) and a fragment of their one error line.
BROKEN = {
    # a problem that does not exist, for every command
    "fit missing problem": (["fit", MISSING, "--out", "{OUT}"], "not found"),
    "simulate missing problem": (["simulate", MISSING, "--out", "{OUT}"], "not found"),
    "joint missing problems": (["joint", MISSING, MISSING / "b", "--out", "{OUT}"], "not found"),
    "joint missing joint file": (["joint", PROBLEMS / "no-such-joint.toml", "--out", "{OUT}"], "not found"),
    "montecarlo missing problem": (["montecarlo", MISSING, "--out", "{OUT}", "--cases", "2"], "no-such-problem"),
    "estimator missing problem": (["montecarlo", MISSING, "--estimator", "--out", "{OUT}"], "not found"),
    "fisher missing problem": (["sensitivity", "fisher", MISSING, "--out", "{OUT}"], "not found"),
    "profile missing problem": (["sensitivity", "profile", MISSING, "--out", "{OUT}"], "not found"),
    "design missing problem": (["sensitivity", "design", MISSING, "--out", "{OUT}"], "not found"),
    "inspect missing file": (["inspect", MISSING / "gps.csv"], "no such file"),
    "inspect a folder": (["inspect", DROP], "directory"),
    "report missing folder": (["report", MISSING], "does not exist"),
    "report a problem folder": (["report", DROP], "not a casrecon results folder"),
    "fit a data file as problem": (["fit", DROP / "data" / "imu.csv", "--out", "{OUT}"], "TOML"),
    # unknown parameter names list the known ones
    "profile unknown parameter": (["sensitivity", "profile", DROP, "--out", "{OUT}", "--parameter", "Cmq"],
                                  "known: CA_mult"),
    "design unknown parameter": (["sensitivity", "design", DROP, "--out", "{OUT}", "--parameter", "nope"],
                                 "known: CA_mult"),
    "design non-aero parameter": (["sensitivity", "design", DROP, "--out", "{OUT}", "--parameter",
                                   "clock_offset_s"], "aero dispersion factor"),
    # Dask scheduler addresses
    "montecarlo scheduler not a url": (["montecarlo", DROP, "--out", "{OUT}", "--cases", "2", "--scheduler",
                                        "not a url"], "not a scheduler address"),
    "estimator scheduler not a url": (["montecarlo", DROP, "--estimator", "--out", "{OUT}", "--scheduler",
                                       "not a url"], "not a scheduler address"),
    "montecarlo scheduler unreachable": (["montecarlo", DROP, "--out", "{OUT}", "--cases", "2", "--scheduler",
                                          "tcp://127.0.0.1:{PORT}"], "cannot reach the Dask scheduler"),
    "estimator scheduler unreachable": (["montecarlo", DROP, "--estimator", "--out", "{OUT}", "--scheduler",
                                         "tcp://127.0.0.1:{PORT}"], "cannot reach the Dask scheduler"),
    # numbers out of range
    "montecarlo more cases than memory": (["montecarlo", DROP, "--out", "{OUT}", "--cases", str(10**12)],
                                          "GB of memory"),
    "montecarlo zero cases": (["montecarlo", DROP, "--out", "{OUT}", "--cases", "0"], "--cases"),
    "montecarlo zero workers": (["montecarlo", DROP, "--out", "{OUT}", "--workers", "0"], "--workers"),
    "montecarlo zero step": (["montecarlo", DROP, "--out", "{OUT}", "--dt", "0"], "--dt"),
    "montecarlo nan step": (["montecarlo", DROP, "--out", "{OUT}", "--dt", "nan"], "--dt"),
    "montecarlo negative seed": (["montecarlo", DROP, "--out", "{OUT}", "--seed", "-1"], "--seed"),
    "estimator one case": (["montecarlo", DROP, "--estimator", "--out", "{OUT}", "--cases", "1"], "--cases"),
    "simulate every zero": (["simulate", DROP, "--out", "{OUT}", "--every", "0"], "--every"),
    "joint one problem": (["joint", DROP, "--out", "{OUT}"], "at least two problems"),
    # options a problem's kind does not have: refused, not silently ignored
    "kinematic check of a point-mass problem": (["fit", PROBLEMS / "realdata-skyderby-411", "--out", "{OUT}",
                                                 "--kinematic-check"], "6-DOF problems only"),
    "solver of a kinematic problem": (["fit", PROBLEMS / "realdata-fs2-chicago-kinematic", "--out", "{OUT}",
                                       "--solver", "ipopt"], "6-DOF problems only"),
}


def expand(args, out, port) -> list[str]:
    return [str(a).replace("{OUT}", str(out)).replace("{PORT}", str(port)) for a in args]


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_broken_arguments_end_in_one_line_and_exit_2(case, tmp_path, capsys):
    args, fragment = BROKEN[case]
    out = tmp_path / "out"
    before = tree_checksums(DROP)
    proc = call_cli(capsys, *expand(args, out, closed_port()))
    assert_clean_failure(proc, 2, fragment)
    assert not out.exists() and leftover_temp_folders(tmp_path) == []
    assert tree_checksums(DROP) == before


@pytest.mark.parametrize("argv", [[], ["frobnicate"], ["fit", str(DROP)], ["fit", str(DROP), "--out", "x", "--hessian",
                                                                         "newton"], ["montecarlo", str(DROP), "--out",
                                                                                     "x", "--cases", "many"]])
def test_usage_errors_exit_2_without_traceback(argv, capsys):
    proc = call_cli(capsys, *argv)
    assert_no_traceback(proc)
    assert proc.returncode == 2 and "usage: casrecon" in proc.stderr


@pytest.mark.parametrize("case", ["profile unknown parameter", "montecarlo scheduler not a url",
                                  "estimator scheduler unreachable", "montecarlo more cases than memory",
                                  "simulate every zero", "fit missing problem", "joint one problem"])
def test_through_the_interpreter(case, tmp_path):
    """The same through ``python -m casrecon`` (the installed entry point's path), in seconds."""
    args, fragment = BROKEN[case]
    out = tmp_path / "out"
    proc = run_cli(*expand(args, out, closed_port()), timeout=60)
    assert_clean_failure(proc, 2, fragment)
    assert not out.exists()


def test_memory_refusal_uses_the_available_memory(tmp_path, capsys, monkeypatch):
    """10 million cases are refused on a machine with 2 GB free (the run was killed by the kernel)."""
    import casrecon.cli_guard as guard

    monkeypatch.setattr(guard, "available_memory_bytes", lambda: 2_000_000_000)
    proc = call_cli(capsys, "montecarlo", DROP, "--out", tmp_path / "mc", "--cases", "10000000")
    line = assert_clean_failure(proc, 2, "--cases 10000000", "2 GB available", "run at most")
    at_most = int(line.split("run at most ")[1].split()[0])
    assert 0 < at_most < 10_000_000


def test_unexpected_error_is_one_line_exit_1_and_debug_shows_the_traceback(tmp_path, capsys, monkeypatch):
    import casrecon.scenario

    def broken(*args, **kwargs):
        raise RuntimeError("a bug\nover two lines")

    monkeypatch.setattr(casrecon.scenario.Scenario, "load", broken)
    args = ["simulate", DROP, "--out", tmp_path / "sim"]
    assert_clean_failure(call_cli(capsys, *args), 1, "unexpected error RuntimeError: a bug over two lines",
                         "--debug")
    with pytest.raises(RuntimeError, match="a bug"):
        call_cli(capsys, "--debug", *args)
    monkeypatch.setenv("CASRECON_DEBUG", "1")
    with pytest.raises(RuntimeError, match="a bug"):
        call_cli(capsys, *args)
    assert leftover_temp_folders(tmp_path) == []


def test_a_keyboard_interrupt_without_a_signal_is_an_error_not_an_interrupt(tmp_path, capsys, monkeypatch):
    """The engine raises KeyboardInterrupt when Ipopt was stopped by an exception outside its callbacks
    (CasADi's own check caught a signal); without a signal that guess was wrong: exit 1, not 130."""
    import casrecon.scenario

    def stopped(*args, **kwargs):
        raise KeyboardInterrupt("Ipopt stopped by an exception outside the callbacks (an interrupt)")

    monkeypatch.setattr(casrecon.scenario.Scenario, "load", stopped)
    proc = call_cli(capsys, "simulate", DROP, "--out", tmp_path / "sim")
    assert_clean_failure(proc, 1, "unexpected error", "Ipopt stopped")


@pytest.mark.parametrize("err, code, fragment", [
    (OSError(errno.EACCES, "Permission denied", "/data/imu.csv"), 2, "/data/imu.csv: Permission denied"),
    (MemoryError(), 2, "not enough memory"),
    (ValueError("tuple.index(x): x not in tuple"), 1, "unexpected error ValueError"),
])
def test_exceptions_map_to_one_line_and_a_documented_status(err, code, fragment):
    status, line = describe(err)
    assert status == code and fragment in line and "\n" not in line and line.startswith("casrecon: ")


def test_no_traceback_marker_is_what_python_prints():
    """The suite looks for this text; it must be what an uncaught exception prints."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", "raise SystemError('x')"], capture_output=True, text=True)
    assert TRACEBACK in proc.stderr


def test_simulate_data_without_a_truth_table_names_the_table_and_that_empty_is_enough(tmp_path, capsys):
    """``simulate --data`` of a problem without ``[truth]``: exit 2 naming the file and the table and
    saying that an empty one will do (it was exit 1, "unexpected error ValueError"); nothing written."""
    text = (DROP / "problem.toml").read_text().replace("../", f"{PROBLEMS.as_posix()}/")
    start, end = text.index("[truth]"), text.index("[simulation]")
    problem = tmp_path / "no-truth"
    problem.mkdir()
    (problem / "problem.toml").write_text(text[:start] + text[end:])
    for name in ("data", "sounding.csv"):
        (problem / name).symlink_to(DROP / name)
    out = tmp_path / "sim"
    proc = call_cli(capsys, "simulate", problem, "--data", "--out", out)
    assert_clean_failure(proc, 2, f"{problem / 'problem.toml'}", "field 'truth'", "no [truth] table",
                         "an empty [truth] is enough")
    assert not out.exists() and leftover_temp_folders(tmp_path) == []
    (problem / "problem.toml").write_text(text[:start] + "[truth]\n\n" + text[end:])
    assert call_cli(capsys, "simulate", problem, "--data", "--out", out).returncode == 0
    assert (out / "truth.json").is_file()
