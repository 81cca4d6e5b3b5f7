"""The public plot API of the aero coefficient histories, the Monte Carlo and the observability
studies: each ``casrecon.plot_*`` returns a Figure from the result object and from the folder the
command writes, saves as a valid PNG and PDF, and refuses what it cannot draw. The Monte Carlo is a
real one (12 cases of ees-drop-1 through ``casrecon.montecarlo``); the fits are stand-ins (no solve)."""

from __future__ import annotations

import io
import re
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import PROBLEMS
from figure_files import assert_figure_file
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import casrecon
from casrecon.analysis.observability import Profile
from casrecon.analysis.sensitivity_documents import design_document, fisher_document, profile_document
from casrecon.cli_montecarlo import run_montecarlo_command
from casrecon.output.results import write_json
from tests.integration.test_report_outputs import make_joint_folder
from tests.unit.test_plots import make_drop_folder

DROP1 = PROBLEMS / "ees-drop-1"
NAMES = ("CA_mult", "Cmq_mult", "wind_bias_n", "gyro_bias_y")


def check(fig: Figure, path) -> None:
    """``fig`` is a Figure with drawn axes, and saves as a valid PNG and PDF."""
    assert isinstance(fig, Figure) and fig.axes
    for suffix in (".png", ".pdf"):
        fig.savefig(path.with_suffix(suffix), dpi=80)
        assert_figure_file(path.with_suffix(suffix))


def test_aero_coefficient_figures_from_a_folder_and_a_result(tmp_path):
    folder = make_drop_folder(tmp_path / "drop")
    check(casrecon.plot_aero_coefficients(folder), tmp_path / "aero_time")
    check(casrecon.plot_aero_coefficients(folder, against="alpha_t"), tmp_path / "aero_alpha")
    check(casrecon.plot_aero_sigma(folder), tmp_path / "aero_sigma")
    tables = SimpleNamespace(figure_source=lambda: casrecon.report.results_folder.DropFolder(folder))
    assert isinstance(casrecon.plot_aero_coefficients(tables), Figure)
    with pytest.raises(ValueError, match="available: time, alpha_t"):
        casrecon.plot_aero_coefficients(folder, against="mach")


def test_montecarlo_figures_from_the_result_and_its_folder(tmp_path):
    mc = casrecon.montecarlo(DROP1, 12, seed=4)
    assert mc.n_cases == 12 and mc.seed == 4 and mc.dispersions == casrecon.Dispersions().resolved(1.0, 0.01)
    check(casrecon.plot_montecarlo_histograms(mc), tmp_path / "hist")
    check(casrecon.plot_montecarlo_impact(mc), tmp_path / "impact")
    check(casrecon.plot_montecarlo_envelopes(mc), tmp_path / "envelopes")
    out = tmp_path / "mc"
    assert run_montecarlo_command(DROP1, out, 12, 4, 1, None, figures=False, progress=False) == 0
    again = casrecon.plot_montecarlo_histograms(out)
    assert [ax.get_xlabel() for ax in again.axes] == [ax.get_xlabel() for ax in
                                                      casrecon.plot_montecarlo_histograms(mc).axes]
    check(casrecon.plot_montecarlo_impact(out), tmp_path / "impact_folder")
    check(casrecon.plot_montecarlo_envelopes(out), tmp_path / "envelopes_folder")
    with pytest.raises(TypeError, match="Monte Carlo result"):
        casrecon.plot_montecarlo_histograms(42)


def fake_fit() -> SimpleNamespace:
    """What the Fisher figure reads of a FitResult: names, scales, specs, sigmas, correlation, name."""
    rng = np.random.default_rng(3)
    a = rng.normal(size=(len(NAMES), len(NAMES) + 3))
    cov = a @ a.T
    sigma = np.sqrt(np.diag(cov))
    scales = np.array([1 / 3, 1 / 3, 1 / 3, np.radians(0.1)])
    specs = [SimpleNamespace(name=n, scale=s, unit="rad/s" if n.startswith("gyro") else "-")
             for n, s in zip(NAMES, scales)]
    params = SimpleNamespace(names=NAMES, scales=scales, specs=specs)
    return SimpleNamespace(params=params, sigma=sigma * scales, correlation=cov / np.outer(sigma, sigma),
                           scenario=SimpleNamespace(config=SimpleNamespace(name="stand-in")))


def test_sensitivity_figures_from_objects_documents_and_folders(tmp_path):
    fit = fake_fit()
    check(casrecon.plot_fisher_directions(SimpleNamespace(fit=fit, params=None)), tmp_path / "fisher")
    doc = fisher_document("stand-in", casrecon.analysis.observability.fisher_directions(fit), fit.params.specs)
    write_json(tmp_path / "fisher.json", doc)
    from_folder = casrecon.plot_fisher_directions(tmp_path)
    assert [t.get_text() for t in from_folder.axes[0].get_xticklabels()] == \
        [t.get_text() for t in casrecon.plot_fisher_directions(fit).axes[0].get_xticklabels()]
    with pytest.raises(TypeError, match="loaded result has no parameter scales"):
        casrecon.plot_fisher_directions(SimpleNamespace(fit=None, params=object()))

    grid = 0.1 + 0.05 * np.linspace(-4, 4, 9)
    profile = Profile("Cmq_mult", grid, 9 * ((grid - 0.1) / 0.15) ** 2, 0.1, 0.15, (-0.05, 0.25))
    check(casrecon.plot_profile_likelihood(profile), tmp_path / "profile")
    write_json(tmp_path / "profile_Cmq_mult.json", profile_document(profile, "-"))
    assert casrecon.plot_profile_likelihood(tmp_path).axes[0].get_title() == \
        casrecon.plot_profile_likelihood(profile).axes[0].get_title()
    assert isinstance(casrecon.plot_profile_likelihood(tmp_path / "profile_Cmq_mult.json"), Figure)
    with pytest.raises(FileNotFoundError, match="profile_CA_mult.json"):
        casrecon.plot_profile_likelihood(tmp_path, "CA_mult")

    design = {"parameter": "Cmq_mult", "pitch_rate": [(0.0, 0.2), (60.0, 0.1)], "altitude": [(800.0, 0.15)],
              "n_drops": [(1, 0.2), (4, 0.1)]}
    check(casrecon.plot_design_study(design), tmp_path / "design")
    write_json(tmp_path / "design.json", design_document(design, "-"))
    lines = casrecon.plot_design_study(tmp_path).axes[0].lines[0]
    assert list(lines.get_xdata()) == [0.0, 60.0] and list(lines.get_ydata()) == [0.2, 0.1]


def panels_of(draw, *args) -> int:
    """How many panels ``draw(*args)`` draws: what its refusal of an empty ``ax`` says."""
    with pytest.raises(ValueError, match=r"ax: this figure draws \d+ panels?: give") as refusal:
        draw(*args, ax=[])
    return int(re.search(r"draws (\d+) panel", str(refusal.value)).group(1))


def test_every_plot_function_draws_on_the_callers_axes(tmp_path):
    """``ax=`` on every ``casrecon.plot_*``: the figure is drawn on the caller's axes (one per panel,
    row-major) and the caller's figure is returned; a wrong number of axes is refused, saying how
    many the figure draws."""
    drop = make_drop_folder(tmp_path / "drop")
    joint = make_joint_folder(tmp_path / "joint")
    mc = casrecon.montecarlo(DROP1, 12, seed=4)
    grid = 0.1 + 0.05 * np.linspace(-4, 4, 9)
    profile = Profile("Cmq_mult", grid, 9 * ((grid - 0.1) / 0.15) ** 2, 0.1, 0.15, (-0.05, 0.25))
    design = {"parameter": "Cmq_mult", "pitch_rate": [(0.0, 0.2), (60.0, 0.1)], "altitude": [(800.0, 0.15)],
              "n_drops": [(1, 0.2), (4, 0.1)]}
    cases = [("plot_trajectory", (drop,)), ("plot_qbar_alpha_t", (drop,)), ("plot_pitching_moment", (drop,)),
             ("plot_reconciled", (drop,)), ("plot_residuals", (drop,)), ("plot_residuals", (drop, "gps")),
             ("plot_correlation", (drop,)), ("plot_correlation", (joint,)), ("plot_aero_coefficients", (drop,)),
             ("plot_aero_coefficients", (drop, "alpha_t")), ("plot_aero_sigma", (drop,)),
             ("plot_joint_altitude_speed", (joint,)), ("plot_joint_qbar_alpha_t", (joint,)),
             ("plot_joint_flow_angles", (joint,)), ("plot_joint_rates", (joint,)),
             ("plot_joint_pitching_moment", (joint,)), ("plot_shared_correlation", (joint,)),
             ("plot_montecarlo_histograms", (mc,)), ("plot_montecarlo_impact", (mc,)),
             ("plot_montecarlo_envelopes", (mc,)), ("plot_fisher_directions", (fake_fit(),)),
             ("plot_profile_likelihood", (profile,)), ("plot_design_study", (design,))]
    assert {name for name, _ in cases} == {n for n in casrecon.__all__ if n.startswith("plot_")}
    for name, args in cases:
        draw = getattr(casrecon, name)
        n = panels_of(draw, *args)
        fig = Figure(figsize=(4.0 * n, 4.0), layout="constrained")
        FigureCanvasAgg(fig)
        axes = fig.subplots(1, n, squeeze=False)[0]
        given = axes[0] if n == 1 else axes
        assert draw(*args, ax=given) is fig, name
        for ax in axes:
            assert ax.lines or ax.collections or ax.images or ax.patches or not ax.get_visible(), (name, ax)
        fig.savefig(io.BytesIO(), format="png", dpi=40)
        with pytest.raises(ValueError, match=f"this figure draws {n} panel"):
            draw(*args, ax=list(axes) + [fig.add_subplot(2, 2, 4)])
