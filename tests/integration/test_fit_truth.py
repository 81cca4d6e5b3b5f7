"""The per-drop fit recovers the synthetic truth of every shipped drop, with honest uncertainties.

Each drop is fitted once per session (about 5 to 8 s each). For every EES drop:

- Ipopt converged;
- every estimated parameter's truth lies within its 3-sigma;
- the reconstructed N, E, D position and velocity lie within their 3-sigma bands of the truth
  history at >= 99 % of the nodes, per component;
- attitude: the rotation-vector error between the estimated and the true attitude (in NED axes,
  q_err = q_est (x) q_true^-1, about 2 vec(q_err)) against its 3-sigma propagated from the
  covariance of the node quaternion, per component, at >= 99 % of the nodes. This is the chosen
  attitude check. Euler roll and yaw are ill-conditioned near pitch -90 deg (a small rotation moves
  them by a lot; their reported sigmas blow up to tens of degrees there, correctly), so the reported
  Euler columns are checked too, with angle wrapping, but the rotation vector is the measure used
  for the final attitude 3-sigma;
- the final 3-sigma of position, velocity and attitude are below the EES paper's 1 m, 0.25 m/s and
  3 deg;
- chi-square / dof is in [0.95, 1.05] (why, see ``test_reduced_chi2``).

The truth history comes from :func:`simulate_truth` on the IMU clock, the same simulation that made
the data, so node times fall exactly on its samples.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import EES_DROPS, PROBLEMS

from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.estimation.sixdof.layout import NS
from casrecon.physics.dynamics import OUTPUT_NAMES
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import simulate_truth, truth_parameters_by_name

POS = ("pos_n_m", "pos_e_m", "pos_d_m")
VEL = ("vel_n_mps", "vel_e_mps", "vel_d_mps")
EULER = (("roll_deg", "roll"), ("pitch_deg", "pitch"), ("yaw_deg", "yaw"))
MIN_INSIDE = 0.99          # fraction of nodes inside the 3-sigma band, per component
PAPER_3SIGMA = {"position_m": 1.0, "velocity_mps": 0.25, "attitude_deg": 3.0}


def hamilton(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton product p (x) q of scalar-first quaternions (K, 4)."""
    p0, p1, p2, p3 = p.T
    q0, q1, q2, q3 = q.T
    return np.column_stack([p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3, p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
                            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1, p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0])


class DropFit:
    """A fit with the truth at its nodes."""

    def __init__(self, name: str) -> None:
        self.scenario = Scenario.load(PROBLEMS / name)
        self.result = fit_drop(self.scenario)
        self.truth = truth_parameters_by_name(self.scenario)
        traj, t_zero = simulate_truth(self.scenario)
        t = t_zero + traj.time_s
        idx = np.searchsorted(t, self.result.node_time_s - 1e-6)
        assert np.all(np.abs(t[idx] - self.result.node_time_s) < 1e-6), "nodes not on the truth grid"
        self.x_true = traj.states[idx]
        self.y_true = traj.outputs[idx]

    def normalised(self, column: str, truth: np.ndarray, wrap: bool = False) -> np.ndarray:
        value, sigma = self.result.column(column)
        err = value - truth
        if wrap:
            err = (err + 180.0) % 360.0 - 180.0
        return err / sigma

    def attitude_error(self) -> tuple[np.ndarray, np.ndarray]:
        """Rotation-vector error (K, 3) in NED axes, rad, and its propagated 1-sigma (K, 3)."""
        q_est = self.result.states[:, 6:10]
        q_true = self.x_true[:, 6:10]
        conj = q_true * np.array([1.0, -1.0, -1.0, -1.0])

        def rotvec(q: np.ndarray) -> np.ndarray:
            q = q / np.linalg.norm(q, axis=1, keepdims=True)
            e = hamilton(q, conj)
            e *= np.sign(e[:, :1])
            ang = 2 * np.arctan2(np.linalg.norm(e[:, 1:], axis=1), e[:, 0])
            return e[:, 1:] * (2.0 / np.sinc(ang / (2 * np.pi)))[:, None]

        err = rotvec(q_est)
        # d(err)/d(q_est) by central differences, then the delta method per node
        eps = 1e-7
        jac = np.zeros((q_est.shape[0], 3, 4))
        for j in range(4):
            dq = np.zeros(4)
            dq[j] = eps
            jac[:, :, j] = (rotvec(q_est + dq) - rotvec(q_est - dq)) / (2 * eps)
        cov = self.result.covariance
        k = q_est.shape[0]
        rows = cov.basis[(NS * np.arange(k)[:, None] + np.arange(6, 10)[None, :])]  # (K, 4, n_w), scale 1
        g = np.einsum("kij,kjw->kiw", jac, rows)
        var = np.einsum("kiw,wv,kiv->ki", g, cov.cov_w, g)
        return err, np.sqrt(var)


@pytest.fixture(scope="session")
def ees_fits():
    return {}


@pytest.fixture(params=EES_DROPS)
def fit(request, ees_fits) -> DropFit:
    name = request.param
    if name not in ees_fits:
        ees_fits[name] = DropFit(name)
    return ees_fits[name]


def test_converged(fit):
    r = fit.result
    assert r.converged, r.solver.status
    assert r.solver.status == "Solve_Succeeded" or r.solver.status.startswith("Converged (Gauss-Newton decrement")


def test_parameters_within_3_sigma(fit):
    r = fit.result
    z = np.array([(v - fit.truth[n]) / s for n, v, s in zip(r.params.names, r.values, r.sigma)])
    print(f"\n{fit.scenario.config.name}: worst |value - truth| / sigma = {np.abs(z).max():.2f} "
          f"({r.params.names[int(np.abs(z).argmax())]})")
    bad = {n: round(float(e), 2) for n, e in zip(r.params.names, z) if abs(e) > 3}
    assert not bad, f"truth outside 3 sigma: {bad}"
    assert np.all(r.sigma > 0)


@pytest.mark.parametrize("columns,state", [(POS, slice(0, 3)), (VEL, slice(3, 6))], ids=["position", "velocity"])
def test_translation_within_bands(fit, columns, state):
    truth = fit.x_true[:, state]
    inside = {}
    for j, c in enumerate(columns):
        inside[c] = float(np.mean(np.abs(fit.normalised(c, truth[:, j])) <= 3))
    print(f"\n{fit.scenario.config.name}: fraction of nodes inside 3 sigma {inside}")
    assert all(f >= MIN_INSIDE for f in inside.values()), inside


def test_attitude_within_bands(fit):
    err, sigma = fit.attitude_error()
    inside = np.mean(np.abs(err) <= 3 * sigma, axis=0)
    print(f"\n{fit.scenario.config.name}: rotation-vector error inside 3 sigma (N, E, D axes) {inside}, "
          f"max error {np.degrees(np.abs(err).max()):.3f} deg")
    assert np.all(inside >= MIN_INSIDE), inside
    # the reported Euler columns, with wrapping (their sigmas carry the pitch -90 deg singularity)
    euler = {c: float(np.mean(np.abs(fit.normalised(c, np.degrees(fit.y_true[:, OUTPUT_NAMES.index(o)]),
                                                    wrap=True)) <= 3)) for c, o in EULER}
    print(f"Euler angles inside 3 sigma {euler}")
    assert all(f >= MIN_INSIDE for f in euler.values()), euler


def test_final_3_sigma_below_paper(fit):
    r = fit.result
    pos = 3 * max(r.column(c)[1][-1] for c in POS)
    vel = 3 * max(r.column(c)[1][-1] for c in VEL)
    _, att_sigma = fit.attitude_error()
    att = 3 * np.degrees(att_sigma[-1].max())
    print(f"\n{fit.scenario.config.name}: final 3-sigma position {pos:.3f} m, velocity {vel:.4f} m/s, "
          f"attitude (rotation vector) {att:.3f} deg")
    assert pos < PAPER_3SIGMA["position_m"]
    assert vel < PAPER_3SIGMA["velocity_mps"]
    assert att < PAPER_3SIGMA["attitude_deg"]


def test_reduced_chi2(fit):
    """With ~110 000 whitened residuals of unit variance, chi2/dof has sd sqrt(2/dof) ~ 0.004, so a
    correct fit lands in 1 +- 0.015 essentially always. The acceptance bound [0.95, 1.05] is the
    issue's: wide enough (>10 sd) never to fail on noise or on the O(h^4) interpolation of the
    specific force, tight enough to catch a mis-weighted group (a noise sigma wrong by 3 % moves the
    IMU chi2, 99 % of the total, by 6 %) or a model that cannot follow the data."""
    r = fit.result
    sd = np.sqrt(2.0 / r.dof)
    print(f"\n{fit.scenario.config.name}: chi2/dof = {r.reduced_chi2:.5f} (dof {r.dof}, sd {sd:.4f}); "
          f"groups {{{', '.join(f'{g}: {v / r.n_measurements[g]:.4f}' for g, v in r.chi2.items())}}}")
    assert 0.95 <= r.reduced_chi2 <= 1.05


def test_davinci_zephyr_fits():
    """The Zephyr (spin vanes, native axes rotated to body): converges, its C_La multiplier and every
    other parameter are recovered within 3 sigma."""
    sc = Scenario.load(PROBLEMS / "davinci-ztu")
    r = fit_drop(sc)
    truth = truth_parameters_by_name(sc)
    assert r.converged
    assert "CLa_mult" in r.params.names
    z = {n: (v - truth[n]) / s for n, v, s in zip(r.params.names, r.values, r.sigma)}
    print(f"\ndavinci-ztu: CLa_mult {r.parameter('CLa_mult')[0]:.4f} +- {3 * r.parameter('CLa_mult')[1]:.4f} "
          f"(3 sigma), truth {truth['CLa_mult']}; worst |err|/sigma {max(map(abs, z.values())):.2f}; "
          f"chi2/dof {r.reduced_chi2:.4f}")
    assert abs(z["CLa_mult"]) <= 3
    assert all(abs(e) <= 3 for e in z.values()), z
    assert 0.95 <= r.reduced_chi2 <= 1.05


def test_trusted_drops_publish_their_own_sigmas(fit):
    """The shipped drops' exact-model fits: trusted, and their time-block sandwich consistent with
    the noise model, so what they publish is the fit's own covariance (issue 49: no widening where
    the model is right)."""
    from casrecon.analysis.fit_products import result_adequacy
    from casrecon.analysis.widened_uncertainty import published_result

    r = fit.result
    assert result_adequacy(r).trusted
    published, widening = published_result(r, True)
    assert widening is None, published.notes
    np.testing.assert_array_equal(published.sigma, r.sigma)
    assert any("consistent with the noise model" in n for n in published.notes)
