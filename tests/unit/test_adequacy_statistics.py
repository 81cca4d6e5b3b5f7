"""The model-adequacy statistics (casrecon.analysis.adequacy) on synthetic white, AR(1) and
mis-scaled series, and on a linear-Gaussian prior problem where the NEES law is known."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from casrecon.analysis.adequacy import FAMILY_ALPHA, Adequacy, GroundCheck, IndependentCheck, assess
from casrecon.analysis.adequacy_tests import (
    channel_test,
    lag1_autocorrelation,
    ljung_box,
    ljung_box_lags,
    prior_nees,
)
from casrecon.analysis.fit_adequacy import joint_adequacy
from casrecon.report.adequacy_block import report_lines


def ar1(rng: np.random.Generator, n: int, phi: float) -> np.ndarray:
    """Unit-variance AR(1) series."""
    e = rng.normal(size=n) * np.sqrt(1 - phi ** 2)
    x = np.empty(n)
    x[0] = rng.normal()
    for k in range(1, n):
        x[k] = phi * x[k - 1] + e[k]
    return x


def test_lag1_autocorrelation_estimates_phi():
    rng = np.random.default_rng(1)
    assert abs(lag1_autocorrelation(rng.normal(size=20000))) < 0.03
    assert lag1_autocorrelation(ar1(rng, 20000, 0.9)) == pytest.approx(0.9, abs=0.02)
    assert np.isnan(lag1_autocorrelation(np.ones(10)))


def test_ljung_box_matches_its_formula_and_is_uniform_on_white_noise():
    rng = np.random.default_rng(2)
    x = rng.normal(size=50)
    d = x - x.mean()
    rho = [d[:-k] @ d[k:] / (d @ d) for k in (1, 2, 3)]
    q = 50 * 52 * sum(r ** 2 / (50 - k) for k, r in zip((1, 2, 3), rho))
    assert ljung_box(x, 3)[0] == pytest.approx(q, rel=1e-12)
    p = np.array([ljung_box(rng.normal(size=200), ljung_box_lags(200))[1] for _ in range(2000)])
    # p-values of white noise are uniform: 5 % below 0.05 (binomial sd 0.5 %), median 0.5
    assert np.mean(p < 0.05) == pytest.approx(0.05, abs=0.016)
    assert np.median(p) == pytest.approx(0.5, abs=0.05)


def test_channel_test_passes_white_and_flags_ar1_and_wrong_scale():
    rng = np.random.default_rng(3)
    alpha = FAMILY_ALPHA / 26
    white = channel_test("GPS vel n", rng.normal(size=200), alpha)
    assert white.white and white.scale_ok and white.lags == 10
    correlated = channel_test("GPS vel n", ar1(rng, 200, 0.9), alpha)
    assert not correlated.white and correlated.ljung_box_p < 1e-10
    # a noise sigma 20 % too small: reduced chi-square 1.44 on 20000 samples
    scaled = channel_test("IMU accel x", 1.2 * rng.normal(size=20000), alpha)
    assert scaled.white and not scaled.scale_ok and scaled.reduced_chi2 > scaled.chi2_interval[1]
    # NaN (no fix) is dropped, not counted
    gaps = channel_test("GPS pos n", np.r_[rng.normal(size=100), np.nan, rng.normal(size=99)], alpha)
    assert gaps.n == 199


def test_prior_nees_is_chi_square_on_a_linear_gaussian_problem():
    """theta ~ N(0, P0), y = H theta + e: the MAP's deviations from the prior give NEES ~ chi2(dof)."""
    rng = np.random.default_rng(4)
    n, m = 6, 8
    s0 = np.array([1.0, 2.0, 0.5, 3.0, 1.0, 0.1])
    h = rng.normal(size=(m, n))
    h[:, 5] *= 1e-3                        # a parameter the data do not inform: left out
    p_post = np.linalg.inv(h.T @ h + np.diag(1 / s0 ** 2))
    values = []
    for _ in range(1500):
        theta = s0 * rng.normal(size=n)
        y = h @ theta + rng.normal(size=m)
        values.append(p_post @ h.T @ y)
    nees = [prior_nees(v, s0, p_post, 0.01) for v in values]
    assert {r.dof for r in nees} == {5}
    stat = np.array([r.nees for r in nees])
    assert stat.mean() == pytest.approx(5.0, abs=0.25)
    assert stats.kstest(stat, stats.chi2(5).cdf).pvalue > 0.01
    # biased estimates (a wrong input pushes the parameters) are flagged
    assert prior_nees(values[0] + 4 * s0, s0, p_post, 0.01).too_large


def white_channels(rng: np.random.Generator) -> dict[str, np.ndarray]:
    return {f"GPS {c}": rng.normal(size=200) for c in ("pos n", "pos e", "pos d", "vel n", "vel e", "vel d")}


def test_verdict_false_alarm_rate_on_an_exact_model_is_below_the_family_level():
    rng = np.random.default_rng(5)
    s0 = np.full(4, 0.5)
    p_post = np.diag(np.full(4, 0.01))
    flags = 0
    runs = 300
    for _ in range(runs):
        values = rng.normal(size=4) * np.sqrt(0.25 - 0.01)
        flags += not assess(white_channels(rng), ["a", "b", "c", "d"], values, s0, p_post).trusted
    # Bonferroni keeps the family-wise rate at or below 1 %: at most 10 of 300 (binomial 99.9 % bound);
    # 17 tests each at 1 % would flag about 16 %
    assert flags <= 10


def test_verdict_names_what_fails():
    rng = np.random.default_rng(6)
    channels = white_channels(rng)
    channels["GPS vel n"] = ar1(rng, 200, 0.93)
    ground = GroundCheck("impact", 302.0, 31.0, "impact 302 m above")
    a = assess(channels, ["CA_mult", "wind_bias_n"], np.array([4.1 / 3, 0.1]), np.array([1 / 3, 1 / 3]),
               np.diag([0.001, 0.001]), ground=ground)
    assert not a.trusted
    assert a.line.startswith("bands NOT to be trusted: GPS vel n residuals correlated (lag-1 0.9")
    assert "CA_mult +4.1 sigma from the prior" in a.line
    assert "impact 302 m above the site's ground" in a.line
    assert "GPS errors are time-correlated" in a.line
    assert [d.name for d in a.deviations] == ["CA_mult"]
    assert a.channel("GPS vel n").lag1 > 0.8
    with pytest.raises(KeyError, match="channels: GPS pos n"):
        a.channel("baro")
    block = "\n".join(report_lines(a))
    assert "VERDICT: bands NOT to be trusted" in block and "Ljung-Box(10)" in block


def test_trusted_verdict_mentions_a_parameter_beyond_3_sigma_within_the_family_limit():
    rng = np.random.default_rng(7)
    a = assess(white_channels(rng), ["CA_mult"], np.array([3.2 / 3]), np.array([1 / 3]), np.array([[0.001]]))
    assert a.z_limit > 3.2 and a.trusted
    assert "CA_mult +3.2 sigma from its prior, within the family-wise" in a.line


def test_ground_check_both_ways():
    assert GroundCheck("impact", -25.0, 30.0, "").ok and not GroundCheck("impact", -302.0, 30.0, "").ok
    assert GroundCheck("lowest", 800.0, 30.0, "").ok and not GroundCheck("lowest", -40.0, 30.0, "").ok


def test_round_trip_through_json():
    rng = np.random.default_rng(8)
    a = assess(white_channels(rng), ["CA_mult"], np.array([5.0 / 3]), np.array([1 / 3]), np.array([[0.001]]),
               ground=GroundCheck("impact", 1.0, 30.0, "ok"), notes=("a note",))
    again = Adequacy.from_dict(json.loads(json.dumps(a.to_dict())))
    assert again == a


def test_residuals_smaller_than_their_sigmas_make_conservative_bands_not_untrusted_ones():
    rng = np.random.default_rng(8)
    channels = white_channels(rng)
    channels["GPS pos n"] = 0.2 * channels["GPS pos n"]
    a = assess(channels, [], np.zeros(0), np.zeros(0), np.zeros((0, 0)))
    assert a.trusted and not a.reasons
    assert a.line.startswith("bands can be trusted, and are conservative: residuals smaller than their sigmas: "
                             "GPS pos n 0.0")
    assert "sigmas are pessimistic" in a.line
    assert len(a.cautions) == 1 and a.cautions[0].startswith("GPS pos n reduced chi-square 0.0")
    assert Adequacy.from_dict(json.loads(json.dumps(a.to_dict()))) == a
    assert any(line.endswith("<- small") for line in report_lines(a))
    joint = joint_adequacy({"a": a, "b": assess(white_channels(rng), [], np.zeros(0), np.zeros(0), np.zeros((0, 0)))})
    assert joint.trusted and "conservative on a (residuals smaller than their sigmas: a: GPS pos n" in joint.line
    # too large is a failure, and a failure elsewhere keeps the small channel named after it
    channels["GPS pos e"] = 3.0 * channels["GPS pos e"]
    a = assess(channels, [], np.zeros(0), np.zeros(0), np.zeros((0, 0)))
    assert not a.trusted and a.reasons == (a.reasons[0],) and "GPS pos e" in a.reasons[0]
    assert a.line.startswith("bands NOT to be trusted: reduced chi-square above its interval: GPS pos e")
    assert "; also residuals smaller than their sigmas: GPS pos n" in a.line


def test_an_independent_check_is_one_test_and_fails_beyond_the_family_limit():
    rng = np.random.default_rng(5)
    channels = white_channels(rng)
    args = (["CA_mult"], np.array([0.1]), np.array([1 / 3]), np.array([[0.001]]))
    without = assess(channels, *args)
    close = assess(channels, *args, checks=(IndependentCheck("accelerometer bias", 1.5, "fit 0.1, kinematic 0.09"),))
    assert close.trusted and close.n_tests == without.n_tests + 1
    limit = close.z_limit
    far = assess(channels, *args, checks=(IndependentCheck("accelerometer bias", -(limit + 0.1), "fit 0.1, kin 0.0"),))
    assert not far.trusted
    assert far.reasons[-1].startswith("accelerometer bias: fit 0.1, kin 0.0") and "sigma apart" in far.reasons[-1]
    assert "without the model" in far.line  # the hint
    assert assess(channels, *args, checks=(IndependentCheck("b", limit - 0.01, "t"),)).trusted
