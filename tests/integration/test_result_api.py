"""Issue 52: results that read like lmfit and pandas. One fit of ees-drop-1 (about 5 s) and one
point-mass fit of realdata-fs1-byron (about 8 s) per module, each also saved and loaded back; the
joint items on the small synthetic joint folder of ``tests/unit/test_api.py`` (no solve)."""

from __future__ import annotations

import datetime
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import casrecon
from casrecon.physics.aero import DISPERSION_NAMES
from tests.unit.test_api import make_joint_folder

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def fresh():
    return casrecon.fit(ROOT / "problems" / "ees-drop-1")


@pytest.fixture(scope="module")
def loaded(fresh, tmp_path_factory):
    return casrecon.load_results(fresh.save(tmp_path_factory.mktemp("result-api") / "ees-drop-1"))


@pytest.fixture(scope="module", params=["fresh", "loaded"])
def result(request, fresh, loaded):
    return {"fresh": fresh, "loaded": loaded}[request.param]


@pytest.fixture(scope="module")
def pointmass(tmp_path_factory):
    fit = casrecon.fit(ROOT / "problems" / "realdata-fs1-byron")
    return fit, casrecon.load_results(fit.save(tmp_path_factory.mktemp("result-api") / "byron"))


@pytest.fixture
def joint(tmp_path):
    return casrecon.load_results(make_joint_folder(tmp_path / "joint"))


def parameters_json(result) -> dict:
    return json.loads((result.source / "parameters.json").read_text())


def report_number(report: str, pattern: str) -> float:
    return float(re.search(pattern, report).group(1))


def test_success_chisqr_redchi_and_nfev_are_the_fits_own(result, loaded):
    summary = json.loads((loaded.source / "summary.json").read_text())
    assert result.success is True and result.success == result.converged
    assert result.chisqr == pytest.approx(sum(summary["chi2"].values()), rel=1e-12)
    # the command's report prints the same chi-square and iteration count
    assert result.chisqr == pytest.approx(report_number(result.report(), r"chi-square ([0-9.]+), dof"), abs=0.05)
    assert result.redchi == result.reduced_chi2 == summary["reduced_chi2"]
    assert result.nfev == result.nit == summary["iterations"] == report_number(result.report(), r"in (\d+) iterations")
    assert result.nvarys == len(parameters_json(loaded)["parameters"])


def test_covar_and_correl_are_dataframes_labelled_by_name(result, loaded):
    doc = parameters_json(loaded)
    names = doc["correlation"]["names"]
    correl, covar = result.correl, result.covar
    for frame in (correl, covar):
        assert isinstance(frame, pd.DataFrame) and list(frame.index) == names and list(frame.columns) == names
    np.testing.assert_array_equal(correl.to_numpy(), np.array(doc["correlation"]["matrix"]))
    sigma = np.array([doc["parameters"][n]["sigma"] for n in names])
    np.testing.assert_allclose(np.diag(covar.to_numpy()), sigma ** 2, rtol=1e-15)
    i, j = names.index("CA_mult"), names.index("Cmq_mult")
    assert covar.loc["CA_mult", "Cmq_mult"] == pytest.approx(sigma[i] * sigma[j] * correl.iloc[i, j], rel=1e-15)
    assert correl.loc["Cmq_mult", "CA_mult"] == result.params["Cmq_mult"].correl["CA_mult"]
    assert result.params.correl.equals(correl) and np.array_equal(result.params.correlation, correl.to_numpy())


def test_every_parameter_the_report_lists_is_a_record_with_vary_and_unit(result, loaded):
    listed_fixed = re.findall(r"^\s+(\S+):\s+0 \(fixed\)", result.report(), flags=re.M)
    assert listed_fixed, "ees-drop-1 holds some dispersion factors fixed"
    for name in listed_fixed:
        p = result.params[name]  # was KeyError
        assert (p.vary, p.fixed, p.value, p.stderr, p.unit, p.group) == (False, True, 0.0, 0.0, "-", "aero")
        assert dict(p.correl) == {}
    entries = parameters_json(loaded)["parameters"]
    assert list(result.params) == list(entries) + listed_fixed
    assert set(result.params) >= set(DISPERSION_NAMES)
    for name, entry in entries.items():
        assert result.params[name].vary and result.params[name].unit == entry["unit"]
    assert result.params.var_names == result.params.names == tuple(entries)
    frame = result.params.to_frame()
    assert list(frame.index) == list(result.params) and frame.loc["CLa_mult", "vary"] == False  # noqa: E712
    assert frame.loc["gyro_bias_x", "unit"] == "deg/s"


def test_valuesdict_and_pretty_print(result, capsys):
    values = result.params.valuesdict()
    assert list(values) == list(result.params)
    assert values["CA_mult"] == result.params["CA_mult"].value and values["CLa_mult"] == 0.0
    result.params.pretty_print()
    lines = capsys.readouterr().out.splitlines()
    assert "Stderr (1-sigma)" in lines[0] and "3-sigma" in lines[0] and "Vary" in lines[0]
    assert len(lines) == 1 + len(result.params)
    row = {line.split()[0]: line.split() for line in lines[1:]}
    assert row["CLa_mult"][1:] == ["0", "fixed", "False", "-"]
    ca = result.params["CA_mult"]
    assert float(row["CA_mult"][1]) == pytest.approx(ca.value, rel=1e-5)
    assert float(row["CA_mult"][2]) == pytest.approx(ca.stderr, rel=1e-3)
    assert float(row["CA_mult"][3]) == pytest.approx(3 * ca.stderr, rel=1e-3)


def test_fit_report_names_1_and_3_sigma(result):
    text = result.fit_report()
    assert text.startswith("[[Fit Statistics]]") and "[[Variables]]" in text and "[[Correlations]]" in text
    assert f"reduced chi-square = {result.redchi:.6g}" in text and f"iterations         = {result.nfev}" in text
    for name in result.params:
        p = result.params[name]
        line = next(x for x in text.splitlines() if x.strip().startswith(f"{name}:"))
        if p.vary:
            assert f"+/- {p.stderr:.4g} (1-sigma), +/- {3 * p.stderr:.4g} (3-sigma) [{p.unit}]" in line, line
        else:
            assert line.rstrip().endswith("0 (fixed) [-]"), line
    strongest = max(((abs(v), a, b) for a in result.correl for b, v in result.correl[a].items() if a != b))
    assert f"C({strongest[1]}, {strongest[2]})" in text or f"C({strongest[2]}, {strongest[1]})" in text
    assert text.splitlines()[-1] == f"    VERDICT: {result.adequacy.line}"
    # the report casrecon fit writes is this text, fresh or loaded (one report style, issue 52)
    assert text == result.report()


def test_parameter_repr_says_which_sigma_it_shows(result):
    p = result.params["CA_mult"]
    assert repr(p) == f"<Parameter 'CA_mult', value={p.value:.6g} +/- {p.stderr:.3g} (1-sigma) [-]>"
    assert repr(result.params["CLa_mult"]) == "<Parameter 'CLa_mult', value=0 (fixed) [-]>"


def test_json_sigma_names_are_aliases_of_stderr(result, loaded):
    entries = parameters_json(loaded)["parameters"]
    for name, entry in entries.items():
        p = result.params[name]
        assert p.sigma == p.stderr == entry["sigma"]
        assert p.sigma_chi2_scaled == p.stderr_scaled == entry["sigma_chi2_scaled"]
    np.testing.assert_array_equal(result.params.sigma, [e["sigma"] for e in entries.values()])


def test_aero_coefficients_are_a_dataframe(result, loaded):
    aero = result.aero_coefficients
    assert isinstance(aero, pd.DataFrame) and aero is result.tables["aero_coefficients.csv"]
    for c in ("flight_time_s", "alpha_t_deg", "CA_reconstructed", "CA_reconstructed_3sigma", "CA_best_fit",
              "CA_nominal", "Cm_reconstructed"):
        assert c in aero.columns, c
    on_file = pd.read_csv(loaded.source / "aero_coefficients.csv")
    assert list(aero.columns) == list(on_file.columns)
    np.testing.assert_allclose(aero.to_numpy(float), on_file.to_numpy(float), rtol=5e-9, atol=1e-12)


def test_sample_by_utc(result):
    tr = result.trajectory
    by_time = result.sample(["alpha_t_deg", "qbar_pa"], tr["flight_time_s"].iloc[[40, 41]].to_numpy() + 0.01)
    instants = tr["utc"].iloc[[40, 41]] + pd.Timedelta(seconds=0.01)
    for given in (instants, list(instants), [t.to_pydatetime() for t in instants],
                  [t.tz_localize(None).to_datetime64() for t in instants],
                  [t.tz_convert("America/Denver") for t in instants]):
        s = result.sample(["alpha_t_deg", "qbar_pa"], given)
        assert list(s.columns) == ["utc", "alpha_t_deg", "alpha_t_deg_3sigma", "qbar_pa", "qbar_pa_3sigma"]
        assert (s["utc"] == instants.to_numpy()).all()
        np.testing.assert_allclose(s.drop(columns="utc").to_numpy(), by_time.drop(columns="flight_time_s").to_numpy(),
                                   rtol=1e-6)
    one = result.sample("qbar_pa", instants.iloc[0].to_pydatetime().replace(tzinfo=None))  # naive: UTC
    assert one["qbar_pa"].iloc[0] == pytest.approx(by_time["qbar_pa"].iloc[0], rel=1e-6)
    with pytest.raises(ValueError, match="outside the fit window"):
        result.sample("qbar_pa", tr["utc"].iloc[0] - pd.Timedelta(seconds=5))
    with pytest.raises(ValueError, match="UTC instants are sampled on time_unix_s"):
        result.sample("qbar_pa", instants, time="flight_time_s")
    with pytest.raises(ValueError, match="time must be one of"):
        result.sample("qbar_pa", [1.0], time="utc")


def test_joint_fit_trajectory_and_sample_per_drop(joint):
    assert set(joint.trajectory) == {"drop-a", "drop-b"}
    assert joint.trajectory["drop-b"] is joint.drops["drop-b"].trajectory
    a = joint.sample(["h_agl_m", "qbar_pa"], [1.0, 2.5], drop="drop-a")
    assert a.equals(joint.drops["drop-a"].sample(["h_agl_m", "qbar_pa"], [1.0, 2.5]))
    both = joint.sample("h_agl_m", [1.0, 2.5])
    assert list(both.columns) == ["drop", "flight_time_s", "h_agl_m", "h_agl_m_3sigma"]
    assert list(both["drop"]) == ["drop-a", "drop-a", "drop-b", "drop-b"]
    np.testing.assert_allclose(both["h_agl_m"], 400 - 35 * np.array([1.0, 2.5, 1.0, 2.5]), rtol=1e-8)
    utc = joint.drops["drop-b"].trajectory["utc"].iloc[5]
    assert joint.sample("h_agl_m", utc, drop="drop-b")["utc"].iloc[0] == utc
    with pytest.raises(ValueError, match="no drop 'drop-c'; the drops are drop-a, drop-b"):
        joint.sample("h_agl_m", [1.0], drop="drop-c")
    assert joint.aero_coefficients == {"drop-a": None, "drop-b": None}


def test_joint_fit_reads_like_lmfit(joint):
    assert joint.success is True and joint.chisqr == 240.0 and joint.redchi == 240 / 230 and joint.nfev is None
    assert joint.params.var_names == ("CA_mult", "drop-a.wind_bias_n", "drop-b.wind_bias_n")
    held = [n for n in joint.params if joint.params[n].fixed]
    assert held == [n for n in DISPERSION_NAMES if n != "CA_mult"]
    assert list(joint.correl.index) == list(joint.params.var_names)
    assert joint.covar.loc["CA_mult", "CA_mult"] == pytest.approx(0.01 ** 2, rel=1e-12)
    text = joint.fit_report()
    assert "(joint 6-DOF of 2 drops)" in text and "+/- 0.01 (1-sigma), +/- 0.03 (3-sigma)" in text
    assert "Cmq_mult:" in text


def test_point_mass_fit_reads_like_lmfit(pointmass):
    fit, loaded = pointmass
    summary = json.loads((loaded.source / "summary.json").read_text())["fit"]
    for r in (fit, loaded):
        assert r.success and r.nfev == summary["iterations"] and r.redchi == summary["reduced_chi2"]
        assert r.chisqr == pytest.approx(sum(summary["chi2"].values()), rel=1e-12)
        assert all(r.params[n].vary for n in r.params) and r.nvarys == len(r.params)
        names = list(r.params)
        assert list(r.covar.index) == names
        np.testing.assert_allclose(np.diag(r.covar.to_numpy()), r.params.stderr ** 2, rtol=1e-15)
        assert np.isnan(r.correl.iloc[0, 1])  # point-mass fits record no correlations
        assert "[[Correlations]]" in r.fit_report() and "not recorded for this kind of fit" in r.fit_report()
    utc = loaded.trajectory["utc"].iloc[[3, 4]]
    s = loaded.sample("cda_m2", utc)
    np.testing.assert_allclose(s["cda_m2"], loaded.trajectory["cda_m2"].iloc[[3, 4]], rtol=1e-9)
    naive = datetime.datetime.fromtimestamp(loaded.trajectory["time_unix_s"].iloc[3], tz=datetime.UTC)
    assert loaded.sample("cda_m2", naive.replace(tzinfo=None))["cda_m2"].iloc[0] == pytest.approx(s["cda_m2"].iloc[0])
