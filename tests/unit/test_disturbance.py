"""Disturbance input (gusts, model-error force and moment): sign conventions by hand, the
Gauss-Markov process, its configuration, the simulator path, and the weak-constraint NLP's block
derivatives and sparse-KKT covariance against CasADi and a dense KKT inverse."""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.io.errors import InputError
from casrecon.io.problem import load_problem
from casrecon.physics.disturbance import DisturbanceModel
from casrecon.physics.dynamics import DISTURBANCE_NAMES, default_parameters
from casrecon.physics.rotations import dcm_body_to_ned
from casrecon.scenario import Scenario
from casrecon.simulation.simulate import Simulator

GUSTS_AND_ERRORS = DisturbanceModel((0.5, 0.5, 0.3, 2.0, 2.0, 2.0, 0.5, 0.5, 0.5), (3.0,) * 3 + (1.0,) * 6)


@pytest.fixture(scope="module")
def drop3():
    return Scenario.load(PROBLEMS / "ees-drop-3")


def _d(**kw) -> np.ndarray:
    d = np.zeros(len(DISTURBANCE_NAMES))
    for k, v in kw.items():
        d[DISTURBANCE_NAMES.index(k)] = v
    return d


def test_gust_equal_to_relative_velocity_removes_the_air_load(drop3):
    """Wind is the air's velocity: a gust that makes the air move with the vehicle leaves no
    aerodynamic force, so dv/dt is gravity plus Coriolis only (the aerodynamics-off model)."""
    m = drop3.model
    x, p = drop3.release_state(), default_parameters()
    x[3:6] = [12.0, -4.0, 30.0]
    y = np.asarray(m.outputs(x, p)).ravel()
    alt = drop3.config.site.ground_alt_msl_m - x[2]
    wind = np.asarray(drop3.atmosphere.at(alt).wind_ned).ravel()  # the sounding's wind there
    gust = x[3:6] - wind
    xdot = np.asarray(m.rhs_d(x, p, _d(gust_n=gust[0], gust_e=gust[1], gust_d=gust[2]))).ravel()
    off = Scenario.from_config(replace(drop3.config, dynamics=replace(drop3.config.dynamics, aerodynamics=False)))
    want = np.asarray(off.model.rhs(x, p)).ravel()
    assert y.shape[0] > 0
    assert xdot[3:6] == pytest.approx(want[3:6], abs=1e-9)


def test_model_error_force_and_moment_by_hand(drop3):
    m = drop3.model
    x, p = drop3.release_state(), default_parameters()
    base = np.asarray(m.rhs(x, p)).ravel()
    mass = drop3.config.vehicle.mass_kg
    # 1 g of body-x force error accelerates along the body x axis expressed in NED
    got = np.asarray(m.rhs_d(x, p, _d(force_x=mass * 9.80665))).ravel()
    c_nb = np.asarray(dcm_body_to_ned(x[6:10]), float)
    assert got[3:6] - base[3:6] == pytest.approx(9.80665 * c_nb[:, 0], abs=1e-9)
    # a body-y moment error of 1 N m adds I^-1 (0, 1, 0) to dw/dt
    got = np.asarray(m.rhs_d(x, p, _d(moment_y=1.0))).ravel()
    inertia = np.asarray(drop3.config.vehicle.inertia_kgm2)
    assert got[10:13] - base[10:13] == pytest.approx(np.linalg.solve(inertia, [0.0, 1.0, 0.0]), abs=1e-12)


def test_gauss_markov_statistics():
    gm = DisturbanceModel((2.0,) + (0.0,) * 8, (0.5,) * 9)
    t = np.arange(0, 20000.0, 0.1)
    d = gm.sample(t, np.random.default_rng(1))
    assert np.all(d[:, 1:] == 0)
    # 4000 correlation times: the sample sd is within a few percent of sigma
    assert d[:, 0].std() == pytest.approx(2.0, rel=0.05)
    lag1 = np.corrcoef(d[:-1, 0], d[1:, 0])[0, 1]
    assert lag1 == pytest.approx(np.exp(-0.1 / 0.5), abs=0.01)
    assert gm.step_sigma(0.1) == pytest.approx(2.0 * np.sqrt(1 - np.exp(-0.4)))


def test_constant_gust_in_the_simulator_equals_a_wind_bias(drop3):
    sim = Simulator(drop3.model, dt_s=0.01)
    x0 = drop3.release_state()
    biased = sim.run(x0, default_parameters(wind_bias_n=2.0, wind_bias_e=-1.0), t_max_s=5.0)
    gusty = sim.run(x0, default_parameters(), t_max_s=5.0,
                    disturbance=lambda t: np.tile(_d(gust_n=2.0, gust_e=-1.0), (t.size, 1)))
    assert gusty.states == pytest.approx(biased.states, abs=1e-9)
    assert gusty.outputs == pytest.approx(biased.outputs, abs=1e-8)
    with pytest.raises(ValueError, match="shape"):
        sim.run(x0, default_parameters(), t_max_s=1.0, disturbance=lambda t: np.zeros((t.size, 3)))


def test_config_reads_and_checks_the_disturbance(tmp_path):
    src = (PROBLEMS / "ees-drop-3" / "problem.toml").read_text()
    folder = PROBLEMS / "ees-drop-3"
    keys = "gust_sigma_mps = [1.0, 1.0, 0.5]\ngust_time_s = 4.0\nmoment_error_sigma_nm = [0.0, 0.2, 0.0]\n"
    text = src.replace("[estimation]", "[estimation]\n" + keys) if "[estimation]" in src else (
        src + "\n[estimation]\n" + keys)
    path = folder / "_disturbance_test.toml"
    try:
        path.write_text(text)
        d = load_problem(path).estimation.disturbance
        assert d.sigma == (1.0, 1.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.2, 0.0)
        assert d.time_s[:3] == (4.0,) * 3 and d.time_s[7] == 1.0
        assert list(d.active) == [0, 1, 2, 7]
        est = load_problem(path).estimation  # no interval_s given: 25 ms, with or without gust states (issue 13)
        assert est.interval_s is None and est.resolved_interval_s() == 0.025 and est.mesh_samples(500.0) == 13
        assert replace(est, disturbance=None).resolved_interval_s() == 0.025
        path.write_text(text.replace("[estimation]\n", "[estimation]\ninterval_s = 0.02\n", 1))
        assert load_problem(path).estimation.resolved_interval_s() == 0.02
        path.write_text(text.replace("gust_sigma_mps = [1.0, 1.0, 0.5]", "gust_sigma_mps = [1.0, -1.0, 0.5]"))
        with pytest.raises(InputError, match="estimation.gust_sigma_mps"):
            load_problem(path)
    finally:
        path.unlink(missing_ok=True)


@pytest.fixture(scope="module")
def short_weak_fit(drop3):
    """A ~1.5 s window of ees-drop-3 fitted with gusts and force and moment errors estimated."""
    cfg = drop3.config
    est = replace(cfg.estimation, start_after_release_s=20.0, end_before_impact_s=17.55, samples_per_interval=25,
                  disturbance=GUSTS_AND_ERRORS)
    return fit_drop(Scenario.from_config(replace(cfg, estimation=est)))


def test_weak_constraint_blocks_match_casadi(short_weak_fit):
    nlp, z = short_weak_fit.nlp, short_weak_fit.solver.z
    z = z + 1e-3 * np.random.default_rng(2).normal(size=z.size)
    jr = ca.Function("jr", [nlp.z], [ca.jacobian(nlp.residuals, nlp.z), nlp.residuals])
    j_r, r = (np.asarray(ca.DM(m).full()) for m in jr(z))
    j_g = np.asarray(ca.Function("jg", [nlp.z], [ca.jacobian(nlp.constraints, nlp.z)])(z).full())
    d = nlp.derivatives
    d._z = None
    grad = d.gradient(z)
    assert grad == pytest.approx(j_r.T @ r.ravel(), rel=1e-9, abs=1e-9 * np.abs(grad).max())
    assert np.asarray(d.jacobian_g(z).toarray()) == pytest.approx(j_g, rel=1e-9, abs=1e-12)
    jtj = np.triu(j_r.T @ j_r)
    assert np.asarray(d.gauss_newton(z).toarray()) == pytest.approx(jtj, rel=1e-9, abs=1e-9 * np.abs(jtj).max())
    # the disturbance columns carry their Gauss-Markov prior rows
    part = short_weak_fit.part
    assert part.u_cols.shape == (part.mesh.t_nodes.size, 9)
    assert "disturbance" in nlp.groups and "disturbance_start" in nlp.groups


def test_sparse_kkt_covariance_equals_dense_inverse(short_weak_fit):
    nlp, z = short_weak_fit.nlp, short_weak_fit.solver.z
    d = nlp.derivatives
    d._z = None
    a = np.asarray(d.jacobian_g(z).toarray())
    hu = np.asarray(d.gauss_newton(z).toarray())
    h = hu + np.triu(hu, 1).T
    n_z, n_g = h.shape[0], a.shape[0]
    dense = np.linalg.inv(np.block([[h, a.T], [a, np.zeros((n_g, n_g))]]))[:n_z, :n_z]
    cov = short_weak_fit.covariance
    part = short_weak_fit.part
    idx = np.r_[part.theta_cols, part.u_cols[7], part.node_cols[13 * 5:13 * 6]]
    want = dense[np.ix_(idx, idx)]
    s = np.sqrt(np.diag(want))
    assert np.max(np.abs(cov.covariance_of(idx) - want) / np.outer(s, s)) < 1e-6
    block = cov.blocks([idx[:5], idx])[1]
    assert np.max(np.abs(block - want) / np.outer(s, s)) < 1e-6
    # the fit reports the estimated disturbances with their bands
    v, sig = short_weak_fit.column("moment_error_y_nm")
    assert v.shape == sig.shape == (part.mesh.t_nodes.size,) and np.all(sig > 0)


def test_gust_fit_on_a_coarse_mesh_says_its_gust_bands_are_too_narrow(short_weak_fit):
    """A 50 ms mesh (25 samples at 500 Hz) with gust states: the report's notes name the mesh and
    the default interval that the calibration study passed with; at 25 ms no such note."""
    from casrecon.estimation.sixdof.fit import GUST_MESH_S, weak_constraint_notes

    notes = [n for n in short_weak_fit.notes if n.startswith("gust states on a")]
    assert len(notes) == 1 and "on a 50 ms mesh" in notes[0] and f"it is then {GUST_MESH_S:g} s" in notes[0]
    fine = replace(short_weak_fit.part, mesh=replace(short_weak_fit.part.mesh, h=GUST_MESH_S))
    assert not [n for n in weak_constraint_notes(fine) if n.startswith("gust states on a")]


def test_midpoint_disturbance_values_enter_the_collocation_and_the_prior(short_weak_fit):
    """The disturbance has unknowns at the nodes and at the interval midpoints, where the
    Hermite-Simpson collocation evaluates the dynamics: the Gauss-Markov prior chains them in time
    order with steps of half an interval, and a midpoint value moves its own interval's defect only."""
    part, nlp, z = short_weak_fit.part, short_weak_fit.nlp, short_weak_fit.solver.z
    k_nodes, n_u = part.mesh.t_nodes.size, part.n_u
    assert part.u_mid_cols.shape == (k_nodes - 1, n_u)
    assert part.n_u_values == (3 * k_nodes - 2) * n_u and part.u_sub_cols.shape == (k_nodes - 1, n_u)
    chain = part.u_chain_cols
    assert np.array_equal(chain[0::2], part.u_cols) and np.array_equal(chain[1::2], part.u_mid_cols)
    assert np.unique(chain).size == chain.size and not np.intersect1d(chain, part.theta_cols).size
    counts = nlp.n_measurements
    assert counts["disturbance_start"] == n_u and counts["disturbance"] == (2 * k_nodes - 2) * n_u
    # the step rows of one process: (u_m - phi u_k) / sqrt(1 - phi^2), phi over h / 2
    d = nlp.derivatives
    d._z = None
    j_g = d.jacobian_g(z).tocsc()
    col = int(part.u_mid_cols[3, 1])  # gust east at the midpoint of interval 3
    rows = set(j_g[:, col].nonzero()[0].tolist())
    node_rows = [set(j_g[:, int(part.node_cols[part.n_states * k + 10])].nonzero()[0].tolist()) for k in (3, 4)]
    assert rows and rows <= node_rows[0] & node_rows[1]  # the defects of interval 3, which joins nodes 3 and 4
