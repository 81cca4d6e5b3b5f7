"""Acceptance on REAL data: ``casrecon fit`` of the three shipped speed-skydive tracks (GPS only,
point mass, drag-area spline with horizontal lift areas, plus the constant-drag comparison).

Each fit runs once per module (module-scoped, parametrised fixture). Run times on this machine,
``casrecon fit`` with figures, in-process: FS1 Byron ~8 s (default suite), skyderby 411 ~10 s and
FS2 Chicago ~14 s (both ``slow``: the three together exceed the ~40 s the default suite can spend
here).

Values measured when the test was first written (white GPS errors, no unmodelled acceleration;
summary.json; reduced chi2 fitted / constant, ratio; constant model vertical-speed residual RMS and
lag-1 autocorrelation):

    FS1 Byron      4.66 / 1039  (x223)   vel_d RMS 42.1, lag-1 0.994
    skyderby 411   6.65 /  443  (x67)    vel_d RMS 38.2, lag-1 0.99
    FS2 Chicago    5.78 / 2962  (x512)   vel_d RMS 89.7, lag-1 1.00

The shipped problems now carry the GPS error model measured on these tracks and an unmodelled
area processes ([model_error]: drag area 25 % log-normal, lift areas 0.02 m^2, over 1 s: the
jumper's changes of body position), and the
verdict tests the Kalman innovations of the fixes. Measured (2026-11-27, velocity errors 94 %
correlated as the problems now say), innovation reduced chi-square per channel: Byron 1.06 to 1.62,
skyderby 0.46 (position east) to 1.98, Chicago 0.58 to 1.49; the innovations stay correlated
(lag-1 up to 0.93), so the verdict still refuses the bands, and says why. The constant-drag
comparison is the strong-constraint fit (reduced chi2 810 to 3188).
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from casrecon.cli import main
from casrecon.physics.atmosphere import Atmosphere
from casrecon.report.results_folder import read_csv

REPO = Path(__file__).resolve().parents[2]
PROBLEMS = REPO / "problems"

FITS = [
    pytest.param("realdata-fs1-byron", id="fs1-byron"),
    pytest.param("realdata-skyderby-411", id="skyderby-411", marks=pytest.mark.slow),
    pytest.param("realdata-fs2-chicago", id="fs2-chicago", marks=pytest.mark.slow),
]


@pytest.fixture(scope="module", params=FITS)
def fitted(request, tmp_path_factory):
    """(name, results folder, exit status, stdout) of ``casrecon fit`` on one real track."""
    name = request.param
    out = tmp_path_factory.mktemp(name) / "results"
    buf = io.StringIO()                      # capsys is function-scoped: capture by hand
    with contextlib.redirect_stdout(buf):
        status = main(["fit", str(PROBLEMS / name), "--out", str(out)])
    return name, out, status, buf.getvalue()


def _summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def test_fit_converges_and_writes_the_folder(fitted):
    name, out, status, stdout = fitted
    assert status == 0, stdout
    assert f"results -> {out}" in stdout
    for f in ("trajectory.csv", "parameters.json", "summary.json", "residuals_gps.csv", "gps_fixes.csv",
              "report.txt", "config/problem.toml", "figures/track_fit.png"):
        assert (out / f).is_file(), f
    png = (out / "figures" / "track_fit.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 50_000
    s = _summary(out)
    assert s["problem"] == name and s["kind"] == "point-mass" and s["converged"] is True
    assert s["fit"]["model"] == "spline" and s["fit"]["lift"] is True and s["fit"]["converged"] is True
    assert s["constant_drag"]["model"] == "constant" and s["constant_drag"]["converged"] is True
    assert (s["fit"]["status"] in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
            or s["fit"]["status"].startswith("Converged (Gauss-Newton decrement"))
    assert "(point-mass, GPS-only)" in stdout and "[[Data notes]]" in stdout


def test_trajectory_has_drag_area_with_three_sigma(fitted):
    name, out, _, _ = fitted
    col = read_csv(out / "trajectory.csv")  # the numeric columns (not the ISO 8601 utc text)
    for c in ("cda_m2", "cda_m2_3sigma", "lift_n_m2", "lift_n_m2_3sigma", "lift_e_m2", "lift_e_m2_3sigma",
              "pos_d_m", "pos_d_m_3sigma", "vel_d_mps", "h_msl_m", "latitude_deg", "longitude_deg"):
        assert c in col, c
    assert all(np.all(np.isfinite(v)) for v in col.values())
    assert np.all(col["cda_m2_3sigma"] > 0) and np.all(col["pos_d_m_3sigma"] > 0)
    assert col["cda_m2"].min() > -1e-6                     # B-spline coefficients >= 0
    # UTC times tie each row to its fix: one receiver period apart, spanning the summary's segment
    s = _summary(out)
    t = col["time_unix_s"]
    assert t[0] == pytest.approx(s["segment_utc_unix_s"][0], abs=1e-3)
    assert t[-1] == pytest.approx(s["segment_utc_unix_s"][1], abs=1e-3)
    period = np.median(np.diff(t))
    assert period in (pytest.approx(0.2, abs=2e-3), pytest.approx(0.1, abs=2e-3))
    assert np.allclose(np.diff(t), period, atol=2e-3)
    assert np.allclose(col["segment_time_s"], t - t[0], atol=2e-3)
    # at top speed a head-down speed skydiver's drag area (for the assumed 80 kg) is small and known
    # to a few per cent; over the whole segment it spans belly (large) to head-down (small)
    top = np.argmax(col["vel_d_mps"])
    assert 0.03 < col["cda_m2"][top] < 0.3, col["cda_m2"][top]
    # with the area process the drag area may change within a second: CdA at top speed is known to
    # 20 to 26 % (3-sigma; 1.7 to 1.9 % with the strong constraint, whose innovations are 20 to 40
    # times their variance, so those sigmas were not credible)
    assert col["cda_m2_3sigma"][top] < 0.3 * col["cda_m2"][top]
    # at the top vertical speed the vertical forces balance (the lift areas are horizontal): the
    # reported CdA (spline plus process) is the whole drag area there
    v_air = np.array([col["vel_n_mps"][top], col["vel_e_mps"][top], col["vel_d_mps"][top]])
    v_air[:2] -= [json.loads((out / "parameters.json").read_text())["parameters"][k]["value"]
                  for k in ("wind_bias_n", "wind_bias_e")]
    levels = Atmosphere.standard().levels
    rho = np.interp(col["h_msl_m"][top], levels["altitude_msl_m"], levels["density_kgm3"])
    balance = 2 * 80.0 * 9.80 / (rho * np.linalg.norm(v_air) * v_air[2])
    print(f"{name}: CdA at top speed {col['cda_m2'][top]:.4f} +- {col['cda_m2_3sigma'][top]:.4f} (3-sigma), "
          f"force balance {balance:.4f} m^2")
    assert abs(col["cda_m2"][top] - balance) < col["cda_m2_3sigma"][top]
    assert col["vel_d_mps"][top] > 90.0


def test_parameters_json(fitted):
    _, out, _, _ = fitted
    p = json.loads((out / "parameters.json").read_text())["parameters"]
    for k in ("wind_bias_n", "wind_bias_e", "CdA_00", "AN_00", "AE_00"):
        assert k in p, k
        assert p[k]["three_sigma"] == pytest.approx(3 * p[k]["sigma"]) and p[k]["sigma"] > 0
    assert p["wind_bias_n"]["unit"] == "m/s" and p["CdA_00"]["unit"] == "m^2"
    assert all(v["value"] >= -1e-6 for k, v in p.items() if k.startswith("CdA_"))


def test_constant_drag_model_leaves_structure(fitted):
    name, out, _, _ = fitted
    s = _summary(out)
    fit, const = s["fit"], s["constant_drag"]
    ratio = const["reduced_chi2"] / fit["reduced_chi2"]
    vd = const["normalised_residuals"]["vel_d"]
    print(f"{name}: reduced chi2 fitted {fit['reduced_chi2']:.2f}, constant {const['reduced_chi2']:.1f} "
          f"(x{ratio:.0f}); constant vel_d RMS {vd['rms']:.1f}, lag-1 {vd['lag1_autocorrelation']:.3f}; "
          f"fitted vel_d RMS {fit['normalised_residuals']['vel_d']['rms']:.2f}")
    assert ratio > 20
    assert fit["reduced_chi2"] < 15
    for comp in ("pos_d", "vel_d"):
        r = const["normalised_residuals"][comp]
        assert r["rms"] > 5 and r["lag1_autocorrelation"] > 0.9, (comp, r)
    # the fitted model removes most of it in every component
    for comp, r in fit["normalised_residuals"].items():
        assert r["rms"] < const["normalised_residuals"][comp]["rms"] / 4, comp
    # same segment and fixes for both models
    assert fit["n_measurements"]["gps"] == const["n_measurements"]["gps"]


def test_verdict_flags_the_correlated_gps_errors(fitted):
    """Real FlySight errors are correlated (lag-1 0.8 to 1.0 under a white model). With the GPS error
    model measured on these tracks and the area processes the innovations have about the right
    scale, but they stay correlated (lag-1 up to 0.7 to 0.9 on every track; Ljung-Box over 10 lags,
    one channel's lag-1 is only 0.19): the verdict says the bands are not to be trusted, and why,
    consistently with its own tests."""
    name, out, _, stdout = fitted
    a = _summary(out)["adequacy"]
    correlated = [c for c in a["channels"] if c["ljung_box_p"] < a["per_test_alpha"]]
    assert a["trusted"] is False and len(correlated) >= 4
    assert max(c["lag1"] for c in correlated) > 0.5
    assert a["line"].startswith("bands NOT to be trusted: ") and "residuals correlated" in a["line"]
    assert "stay correlated under the fit's GPS error model" in a["line"]
    assert f"VERDICT: {a['line']}" in stdout


#: Channels whose innovation reduced chi-square is known to lie below 0.5 (measured; a caution:
#: the reported accuracy is pessimistic there, so the band is wider than the data need).
KNOWN_BELOW_HALF = {"realdata-skyderby-411": {"GPS pos e"}}


def test_innovations_scale_and_no_silent_prior_deviation(fitted):
    """Issue 18's floor for the real tracks: with the GPS error model and the area processes every
    channel's innovation reduced chi-square lies in [0.5, 2] (skyderby's east position, 0.46, is the
    measured exception, below: asserted as such; Chicago's vertical velocity was the other, 0.475,
    until the problems described the velocity errors as 94 % correlated: 0.576);
    a parameter beyond its verdict limit would be named in the line."""
    name, out, _, _ = fitted
    a = _summary(out)["adequacy"]
    innovations = read_csv(out / "residuals_gps.csv")
    for c, component in zip(a["channels"], ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")):
        z = innovations[f"{component}_fit_innovation_z"]   # the series the test read, written
        z = z[np.isfinite(z)]
        assert z.size == c["n"] and np.mean(z * z) == pytest.approx(c["reduced_chi2"], rel=1e-6)
    below = KNOWN_BELOW_HALF.get(name, set())
    for c in a["channels"]:
        print(f"{name} {c['name']}: innovation reduced chi2 {c['reduced_chi2']:.3f}, lag-1 {c['lag1']:+.2f}")
        if c["name"] in below:
            assert c["reduced_chi2"] < 0.5 and any(c["name"] in x for x in a["cautions"]), c
        else:
            assert 0.5 <= c["reduced_chi2"] <= 2.0, c
    for d in a["deviations"]:
        if abs(d["z"]) > a["z_limit"]:
            assert d["name"] in a["line"], d
