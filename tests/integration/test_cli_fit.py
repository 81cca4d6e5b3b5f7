"""`casrecon fit` end to end: the results folder (every figure as PNG and PDF, each file checked),
and failures that leave nothing behind."""

import json

from conftest import PROBLEMS
from figure_files import DROP_FIGURES, assert_figure_file

from casrecon.analysis import aero_columns
from casrecon.cli import main
from casrecon.io.units import unnamed_json_numbers


def _with_estimation(problem_toml, text: str) -> None:
    body = problem_toml.read_text()
    if "[estimation]" in body:
        body = body.replace("[estimation]", "[estimation]\n" + text)
    else:
        body += "\n[estimation]\n" + text
    problem_toml.write_text(body)


def test_fit_writes_the_results_folder(problem_copy, tmp_path, capsys):
    out = tmp_path / "fit"
    assert main(["fit", str(problem_copy), "--out", str(out), "--quiet", "--format", "png,pdf"]) == 0
    names = {p.name for p in out.iterdir()}
    assert {"trajectory.csv", "parameters.json", "summary.json", "tables.md", "report.txt", "config",
            "aero_coefficients.csv"} <= names
    figures = sorted((out / "figures").iterdir())
    assert [p.name for p in figures] == sorted(f"{f}.{x}" for f in DROP_FIGURES for x in ("png", "pdf"))
    for path in figures:
        assert_figure_file(path)
    assert (out / "aero_coefficients.csv").read_text().splitlines()[0].split(",") == list(aero_columns.all_columns())
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is True
    for key in ("build_s", "solve_s", "covariance_s", "total_s", "iterations", "objective", "chi2"):
        assert key in summary
    params = json.loads((out / "parameters.json").read_text())
    truth = json.loads((problem_copy.parent / "data" / "truth.json").read_text())["parameters"]
    assert set(params["parameters"]) <= set(truth)
    assert len(params["correlation"]["matrix"]) == len(params["parameters"])
    header = (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    for col in ("pos_n_m", "h_agl_m", "vel_d_mps", "roll_deg", "p_dps", "alpha_deg", "beta_deg",
                "alpha_t_deg", "qbar_pa", "mach"):
        assert col in header and f"{col}_3sigma" in header
    assert "Table 5" in (out / "tables.md").read_text()
    # the model-adequacy verdict of an exact-model synthetic fit, in summary.json and report.txt
    adequacy = summary["adequacy"]
    assert adequacy["trusted"] is True and adequacy["line"].startswith("bands can be trusted")
    assert [c["name"] for c in adequacy["channels"]][:3] == ["IMU accel x", "IMU accel y", "IMU accel z"]
    assert f"VERDICT: {adequacy['line']}" in (out / "report.txt").read_text()


def test_non_converged_fit_exits_nonzero_and_keeps_the_old_folder(problem_copy, tmp_path, capsys):
    _with_estimation(problem_copy, "max_iter = 2")
    out = tmp_path / "fit"
    out.mkdir()
    (out / "earlier.txt").write_text("an earlier result")
    (out / ".casrecon-results.json").write_text("{}")  # a casrecon results folder (else --out is refused)
    assert main(["fit", str(problem_copy), "--out", str(out), "--quiet"]) == 3
    err = capsys.readouterr().err  # --quiet: no progress lines, only the one failure line
    assert "did not converge" in err and err.count("\n") == 1
    assert sorted(p.name for p in out.iterdir()) == [".casrecon-results.json", "earlier.txt"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".fit.")]


def test_bad_estimation_setting_is_a_located_error(problem_copy, tmp_path, capsys):
    _with_estimation(problem_copy, 'hessian = "newton"')
    assert main(["fit", str(problem_copy), "--out", str(tmp_path / "fit")]) == 2
    err = capsys.readouterr().err
    assert "problem.toml" in err and "estimation.hessian" in err
    assert not (tmp_path / "fit").exists()


def test_sensitivity_fisher_names_the_weakest_combination(tmp_path, capsys):
    out = tmp_path / "fisher"
    assert main(["sensitivity", "fisher", str(PROBLEMS / "ees-drop-2"), "--out", str(out)]) == 0
    doc = json.loads((out / "fisher.json").read_text())
    directions = doc["directions"]
    weakest = directions[0]["loadings"]
    # the balloon's density uncertainty scales every aero force alike: the least determined direction
    assert max(weakest, key=lambda n: abs(weakest[n])) == directions[0]["largest_loading"] == "density_factor"
    assert weakest["density_factor"] > 0 and directions[0]["rank"] == 1
    assert directions[0]["sigma_normalised"] > 10 * directions[-1]["sigma_normalised"]
    assert [d["eigenvalue"] for d in directions] == sorted(d["eigenvalue"] for d in directions)
    assert set(doc["parameters"]) == set(weakest) and (out / "fisher.png").is_file()
    # every number names its unit; the gyro biases' scales in deg/s, as the problem gives them
    assert unnamed_json_numbers(doc) == [] and doc["parameters"]["gyro_bias_x"]["unit"] == "deg/s"
