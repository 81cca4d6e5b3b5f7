"""What ``casrecon fit`` says while it works (issue 52): every stage named in its log, in order, with
the fit's label on the fit's lines; a long stage says it is still running; the refits of the
error-model sizes labelled with their number and what they re-estimate."""

from __future__ import annotations

import logging
import re
import time

import pytest
from conftest import PROBLEMS

from casrecon import progress
from casrecon.cli import main
from casrecon.cli_options import configure_logging
from casrecon.estimation.engine.convergence import (
    fit_stage,
    iteration_log_settings,
    iteration_logging,
    log_iteration,
    nested_label,
)
from casrecon.estimation.sixdof.fit import sizes_named
from casrecon.io.problem import load_problem

#: The stages of a 6-DOF ``casrecon fit`` with figures, in the order they start (regular expressions).
SIX_DOF_STAGES = (r"fit: building the NLP", r"fit: solving", r"fit: iteration 0: chi-square", r"fit: covariance",
                  r"trajectory bands", r"residuals, reconciled simulations, aerodynamic coefficients and model "
                  r"adequacy", r"writing the results -> ", r"figures$", r"figure 1 of 13: ", r"figure 13 of 13: ")


def test_a_fit_names_every_stage_in_order(problem_copy, tmp_path, capsys):
    assert main(["fit", str(problem_copy), "--out", str(tmp_path / "fit")]) == 0
    err = capsys.readouterr().err
    lines = err.splitlines()
    at = [next((i for i, line in enumerate(lines) if re.match(stage, line)), None) for stage in SIX_DOF_STAGES]
    assert None not in at, dict(zip(SIX_DOF_STAGES, at))
    assert at == sorted(at)
    assert "\r" not in err and "compiled " not in err   # a redirected log; compile messages are DEBUG


@pytest.mark.parametrize("name, named", [("ees-drop-1", ""), ("ees-drop-3-model-error", "profile and GPS error sizes"),
                                         ("davinci-ztu", "")])
def test_the_refits_are_named_by_what_they_estimate(name, named):
    assert sizes_named(load_problem(PROBLEMS / name)) == named


def test_fit_stages_carry_the_labels_of_their_blocks(caplog):
    with caplog.at_level(logging.DEBUG, logger="casrecon"):
        with iteration_logging(logging.DEBUG, "case 3"), iteration_logging(label=nested_label("fit 1 of up to 4")):
            with fit_stage("covariance"):
                pass
            log_iteration(*iteration_log_settings(), 2, 10.0, 1e-9)
    messages = [(r.levelno, r.getMessage()) for r in caplog.records]
    assert messages == [(logging.DEBUG, "case 3, fit 1 of up to 4: covariance"),
                        (logging.DEBUG, "case 3, fit 1 of up to 4: iteration 2: chi-square 10, constraint violation "
                                        "1e-09")]


def test_a_long_stage_says_it_is_still_running_and_no_stretch_is_silent(monkeypatch):
    import io

    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.2)
    stream = io.StringIO()
    log = logging.getLogger("casrecon.test_stages")
    stamps = []

    class Stamped(io.StringIO):
        def write(self, text):
            stamps.append(time.monotonic())
            return stream.write(text)

    configure_logging(logging.INFO, Stamped())
    try:
        start = time.monotonic()
        with progress.stage(log, "a slow step"):
            time.sleep(1.0)
        end = time.monotonic()
        with progress.stage(log, "a quick step"):
            pass
    finally:
        configure_logging(logging.WARNING)
    lines = stream.getvalue().splitlines()
    assert lines[0] == "a slow step" and lines[-1] == "a quick step"
    beats = [line for line in lines if line.startswith("a slow step: still running (")]
    assert 3 <= len(beats) <= 6                       # every 0.2 s of a 1 s step
    gaps = [b - a for a, b in zip([start, *stamps], [*stamps, end])]
    assert max(gaps) < 0.45                           # HEARTBEAT_S and a quarter of it (the polling), at most
