"""Quickstart: the public Python API in one notebook-style script (only ``import casrecon``).

Run: python examples/quickstart.py

It fits EES drop 1, prints one parameter record and the lmfit-style report, samples the total angle
of attack at a few flight times, saves the results folder (the same one ``casrecon fit --out``
writes), loads it back and asserts that values, sigmas and correlations are identical, and draws a
figure to a PNG file, all without any other casrecon import.
"""

import tempfile
from pathlib import Path

import numpy as np

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
    print(result.params.to_frame()[["value", "stderr", "unit"]])
    print(result.report())

    # %% The time history is a DataFrame; sample() interpolates any column and its 3-sigma
    times = [1.0, 2.0, 4.0, 6.0]
    alpha = result.sample("alpha_t_deg", times)
    print(alpha)
    assert np.all(alpha["alpha_t_deg_3sigma"] > 0)
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


if __name__ == "__main__":
    main()
