"""CLI conventions (issue 15): ``--version``, defaults in every ``--help``, ``--quiet`` / ``--verbose``
on every command wired to logging, and a fit's per-iteration progress on stderr."""

from __future__ import annotations

import io
import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import casrecon
from casrecon.cli import build_parser, main
from casrecon.cli_options import LOGGER, configure_logging, log_level
from casrecon.estimation.engine.nlp import assemble_nlp
from casrecon.estimation.engine.solve import solve
from tests.unit.test_engine import line_terms

ROOT = Path(__file__).resolve().parents[2]
COMMANDS = ("inspect", "simulate", "fit", "joint", "montecarlo", "sensitivity", "report")
ARGS = {"inspect": ["FILE"], "simulate": ["P", "--out", "O"], "fit": ["P", "--out", "O"],
        "joint": ["A", "B", "--out", "O"], "montecarlo": ["P", "--out", "O"],
        "sensitivity": ["fisher", "P", "--out", "O"], "report": ["R"]}


def run_module(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "casrecon", *args], capture_output=True, text=True, env=env,
                          timeout=120)


def test_version_via_python_m():
    proc = run_module("--version")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"casrecon {casrecon.__version__}"


def test_version_in_process(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"casrecon {casrecon.__version__}"


@pytest.mark.parametrize("command", COMMANDS)
def test_every_help_shows_defaults_and_verbosity(command, capsys):
    assert set(build_parser()._subparsers._group_actions[0].choices) == set(COMMANDS)
    with pytest.raises(SystemExit) as exit_:
        main([command, "--help"])
    assert exit_.value.code == 0
    text = capsys.readouterr().out
    assert "default" in text and "--quiet" in text and "--verbose" in text


def test_numeric_defaults_shown_once():
    text = " ".join(build_parser()._subparsers._group_actions[0].choices["montecarlo"].format_help().split())
    assert "(default: 2)" in text and "(default: 0.02)" in text and text.count("(default") == text.count("default")
    assert "(default: the problem's [montecarlo] cases, 1000 without it" in text


@pytest.mark.parametrize("command", COMMANDS)
def test_quiet_and_verbose_set_the_log_level(command):
    parser = build_parser()
    flags = ([], ["--quiet"], ["--verbose"])
    levels = [log_level(parser.parse_args([command, *ARGS[command], *flag])) for flag in flags]
    assert levels == [logging.INFO, logging.WARNING, logging.DEBUG]
    with pytest.raises(SystemExit):
        parser.parse_args([command, *ARGS[command], "--quiet", "--verbose"])


def _line_fit_log(level: int) -> str:
    stream = io.StringIO()
    configure_logging(level, stream)
    try:
        rng = np.random.default_rng(1)
        t = np.linspace(0.0, 1.0, 40)
        y = 0.3 + 1.7 * t + 0.05 * rng.normal(size=t.size)
        nlp = assemble_nlp(line_terms(t, y, 0.05), 2, dependent=np.zeros(0, int), parameter_names={0: "a", 1: "b"})
        sol = solve(nlp, np.zeros(2))
    finally:
        configure_logging(logging.WARNING)
    assert sol.converged
    chi2 = 2.0 * sol.objective + sum(nlp.const_chi2.values())
    return stream.getvalue(), sol.iterations, chi2


def test_fit_logs_each_ipopt_iteration_with_its_chi_square():
    text, iterations, chi2 = _line_fit_log(logging.INFO)
    lines = text.splitlines()
    assert len(lines) == iterations + 1  # iteration 0 is the starting point
    assert lines[0].startswith("iteration 0: chi-square ")
    last = lines[-1]
    assert last.startswith(f"iteration {iterations}: chi-square ") and ", constraint violation " in last
    assert float(last.split("chi-square ")[1].split(",")[0]) == pytest.approx(chi2, rel=1e-5)


def test_quiet_logging_hides_the_progress():
    text, _, _ = _line_fit_log(logging.WARNING)
    assert text == ""
    assert logging.getLogger(LOGGER).level == logging.WARNING


def test_cli_fit_progress_on_stderr_unless_quiet(tmp_path):
    """The cheapest real fit (a GPS-only point-mass problem, seconds): progress lines on stderr by
    default, each run of the two (spline and constant drag area) labelled, none with --quiet; the
    results line stays on stdout."""
    problem = str(ROOT / "problems" / "realdata-skyderby-411")
    loud = run_module("fit", problem, "--out", str(tmp_path / "a"), "--no-figures")
    assert loud.returncode == 0, loud.stderr
    lines = loud.stderr.splitlines()
    for label in ("spline-CdA fit", "constant-CdA fit"):
        assert sum(line.startswith(f"{label}: iteration ") and "chi-square" in line for line in lines) >= 3, label
    first_constant = next(i for i, line in enumerate(lines) if line.startswith("constant-CdA fit: "))
    assert all(line.startswith("spline-CdA fit: ") for line in lines[:first_constant])  # one run, then the other
    stages = ("spline-CdA fit: solving", "spline-CdA fit: covariance", "spline-CdA fit: drag-area and state sigmas",
              "constant-CdA fit: solving", "constant-CdA fit: covariance", "model adequacy", "writing the results -> ")
    at = [next((i for i, line in enumerate(lines) if line.startswith(stage)), None) for stage in stages]
    assert None not in at and at == sorted(at), dict(zip(stages, at))  # every stage named, in order
    quiet = run_module("fit", problem, "--out", str(tmp_path / "b"), "--no-figures", "--quiet")
    assert quiet.returncode == 0, quiet.stderr
    assert "iteration" not in quiet.stderr and "results ->" in quiet.stdout


def test_profile_logs_one_line_per_grid_point(monkeypatch, caplog):
    from types import SimpleNamespace

    from casrecon.analysis import observability as obs

    result = SimpleNamespace(parameter=lambda name: (1.0, 0.1), solver=SimpleNamespace(objective=10.0))
    monkeypatch.setattr(obs, "refit_with_held", lambda res, name, v: SimpleNamespace(
        objective=10.0 + 50.0 * (v - 1.0) ** 2, converged=True, status="ok"))
    with caplog.at_level(logging.INFO, logger=obs.LOG.name):
        obs.profile_likelihood(result, "Cmq_mult", n_points=5)
    lines = [r.getMessage() for r in caplog.records if r.name == obs.LOG.name]
    assert len(lines) == 5
    assert lines[0] == "profile Cmq_mult: point 1 of 5, Cmq_mult = 0.6: delta chi-square 16"


def _line_result():
    """A converged straight-line fit, shaped like the FitResult ``refit_with_held`` reads."""
    from types import SimpleNamespace

    rng = np.random.default_rng(2)
    t = np.linspace(0.0, 1.0, 40)
    y = 0.3 + 1.7 * t + 0.05 * rng.normal(size=t.size)
    nlp = assemble_nlp(line_terms(t, y, 0.05), 2, dependent=np.zeros(0, int), parameter_names={0: "a", 1: "b"})
    params = SimpleNamespace(names=("a", "b"), index=("a", "b").index, scales=np.ones(2))
    return SimpleNamespace(nlp=nlp, z=solve(nlp, np.zeros(2)).z, params=params,
                           part=SimpleNamespace(theta_cols=np.array([0, 1]), params=params))


def test_profile_refits_log_their_iterations_at_debug_with_a_label(caplog):
    from casrecon.analysis.observability import refit_with_held
    from casrecon.estimation.engine import convergence

    result = _line_result()
    with caplog.at_level(logging.DEBUG, logger=LOGGER):
        sol = refit_with_held(result, "a", 0.5)
        after = solve(result.nlp, np.zeros(2))     # outside the refit: INFO and no label again
    assert sol.converged and sol.z[0] == 0.5
    records = [r for r in caplog.records if r.name == convergence.LOG.name]
    refit, plain = records[:sol.iterations + 1], records[sol.iterations + 1:]
    assert all(r.levelno == logging.DEBUG and r.getMessage().startswith("profile a = 0.5: iteration ") for r in refit)
    assert len(plain) == after.iterations + 1
    assert all(r.levelno == logging.INFO and r.getMessage().startswith("iteration ") for r in plain)


def test_estimator_montecarlo_logs_each_finished_case(caplog):
    from casrecon.analysis.estimator_mc import LOG, CaseLog

    log = CaseLog(3)
    with caplog.at_level(logging.INFO, logger=LOG.name):
        log(2, {"chi2": 12345.6, "reduced_chi2": 1.0123, "nees": 17.5, "iterations": 8, "case_s": 31.25})
        log(0, {"failed": "no convergence", "case_s": 12.0})
    assert [r.getMessage() for r in caplog.records] == [
        "estimator montecarlo: case 2 (1 of 3 done): converged, chi-square 12345.6 (reduced 1.0123), NEES 17.50, "
        "8 iterations, 31.2 s",
        "estimator montecarlo: case 0 (2 of 3 done): fit failed (no convergence), 12.0 s"]
