"""Quickstart: the public Python API in one notebook-style script (only ``import casrecon``).

Run: python examples/quickstart.py

It fits EES drop 1, prints one parameter record, the lmfit-style ``fit_report()`` (1- and
3-sigma named, the fixed factors listed) and the labelled correlation DataFrame, samples the total
angle of attack at a few flight times and at a UTC instant, saves the results folder (the same one
``casrecon fit --out`` writes), loads it back and asserts that values, sigmas and correlations are
identical, and draws figures to PNG files, one of them on axes of its own, all without any other
casrecon import.
"""

import re
import tempfile
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

import casrecon

PROBLEM = Path(__file__).resolve().parents[1] / "problems" / "ees-drop-1"


def main() -> None:
    # %% Fit one drop: about 20 s
    result = casrecon.fit(PROBLEM)
    print(result)
    assert result.converged and 0.9 < result.reduced_chi2 < 1.1, result.reduced_chi2

    # %% A parameter is a record, as in lmfit: value, 1-sigma (absolute and chi2-scaled), correlations
    ca = result.params["CA_mult"]
    print(ca, f"stderr {ca.stderr:.4g}, chi2-scaled {ca.stderr_scaled:.4g}, unit {ca.unit!r}, group {ca.group!r}")
    strongest = max(ca.correl, key=lambda n: abs(ca.correl[n]))
    print(f"CA_mult is most correlated with {strongest}: {ca.correl[strongest]:+.3f}")
    print(result.params.to_frame()[["value", "stderr", "unit", "vary"]])

    # %% lmfit's names and report: success, chisqr, redchi, nfev (the solver's iterations), fit_report()
    assert result.success and result.redchi == result.reduced_chi2 and result.nfev >= 1
    assert result.chisqr == sum(result.chi2.values())
    report = result.fit_report()  # one report style for every kind of fit
    assert report == result.report()  # the report.txt `casrecon fit` writes and prints
    print(report)
    line = next(x for x in report.splitlines() if x.strip().startswith("CA_mult:"))
    assert f"+/- {ca.stderr:.4g} (1-sigma), +/- {3 * ca.stderr:.4g} (3-sigma)" in line, line
    # the factors the fit held at 0 are records too (vary False), as the report lists them
    held = re.findall(r"^\s+(\S+):\s+0 \(fixed\)", report, flags=re.M)
    assert held and all(not result.params[n].vary and result.params[n].value == 0.0 for n in held), held
    result.params.pretty_print()

    # %% The correlation and the covariance are DataFrames labelled by parameter name
    pair = ["CA_mult", "Cmq_mult", "wind_bias_n"]
    print(result.correl.loc[pair, pair].round(3))
    assert result.correl.loc["CA_mult", "Cmq_mult"] == ca.correl["Cmq_mult"]
    assert np.isclose(result.covar.loc["CA_mult", "CA_mult"], ca.stderr ** 2, rtol=1e-12)

    # %% The time history is a DataFrame; sample() interpolates any column and its 3-sigma
    times = [1.0, 2.0, 4.0, 6.0]
    alpha = result.sample("alpha_t_deg", times)
    print(alpha)
    assert np.all(alpha["alpha_t_deg_3sigma"] > 0)
    # or at UTC instants (datetime or pandas Timestamp): here 2 s after the first node
    at = result.trajectory["utc"].iloc[0] + np.timedelta64(2, "s")
    by_utc = result.sample("alpha_t_deg", [at])
    print(by_utc)
    by_time = result.sample("alpha_t_deg", result.trajectory["flight_time_s"].iloc[0] + 2.0)
    assert np.isclose(by_utc["alpha_t_deg"].iloc[0], by_time["alpha_t_deg"].iloc[0], rtol=1e-6)
    print("aero coefficients:", result.aero_coefficients.shape, "(rows, columns)")
    print("residual tables:", {kind: frame.shape for kind, frame in result.residuals.items()})

    with tempfile.TemporaryDirectory() as tmp:
        # %% Save the results folder and load it back: parameters are identical to the last bit
        folder = result.save(Path(tmp) / "ees-drop-1")
        loaded = casrecon.load_results(folder)
        print(loaded)
        assert loaded.params == result.params
        for name in result.params:
            a, b = result.params[name], loaded.params[name]
            assert a.value == b.value and a.stderr == b.stderr and a.stderr_scaled == b.stderr_scaled, name
            assert dict(a.correl) == dict(b.correl), name
        # trajectory.csv holds 9 significant digits: the loaded frame agrees to that precision; its
        # utc column (ISO 8601 in the file) is read as pandas UTC timestamps, to the microsecond
        assert list(loaded.trajectory.columns) == list(result.trajectory.columns)
        np.testing.assert_allclose(loaded.trajectory.select_dtypes("number").to_numpy(),
                                   result.trajectory.select_dtypes("number").to_numpy(), rtol=1e-8, atol=0)
        assert (loaded.trajectory["utc"] == result.trajectory["utc"]).all()
        print("UTC, latitude, longitude, h_MSL at the first node:",
              *loaded.trajectory.loc[0, ["utc", "latitude_deg", "longitude_deg", "h_msl_m"]])
        np.testing.assert_allclose(loaded.sample("alpha_t_deg", times).to_numpy(), alpha.to_numpy(), rtol=1e-8)

        # %% A figure is a matplotlib Figure: save it, or display it in a notebook
        png = Path(tmp) / "trajectory.png"
        casrecon.plot_trajectory(result).savefig(png, dpi=80)
        casrecon.plot_correlation(loaded).savefig(Path(tmp) / "correlation.png", dpi=80)
        assert png.stat().st_size > 10_000
        print(f"figure -> {png} ({png.stat().st_size} bytes)")

        # %% ... or drawn on your own axes (one per panel): ax= returns your figure
        mine = Figure(figsize=(7, 5), layout="constrained")
        ax = mine.subplots()
        assert casrecon.plot_pitching_moment(result, ax=ax) is mine
        assert ax.get_xlabel().startswith("angle of attack") and len(ax.lines) >= 3  # points, nominal, best fit
        ax.set_title("EES drop 1: C_m on my own axes")
        mine.savefig(Path(tmp) / "pitching_moment.png", dpi=80)
        assert (Path(tmp) / "pitching_moment.png").stat().st_size > 10_000


if __name__ == "__main__":
    main()
