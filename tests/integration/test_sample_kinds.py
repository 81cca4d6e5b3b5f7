"""A new measurement kind written once, in this file, and fitted by both the 6-DOF and the kinematic
fit (issue 48): a second GPS antenna giving positions only, at a lever arm of its own, with a
constant 3-vector bias estimated under a 1 m prior and 5 cm white noise.

The kind is a :class:`~casrecon.estimation.kinds.samples.SampleKind`: its samples on the receiver's
clock, its parameters and a prediction from the body's state. Passed to ``fit_drop(...,
sample_kinds=...)`` and ``fit_kinematic(..., sample_kinds=...)`` it needs nothing else; registered
(this file registers it for its tests, as a shipped kind would be), a ``[sensors.antenna2]`` table
in a 6-DOF problem.toml or ``[antenna2]`` in a kinematic one configures it, and the pipelines fit
it. A kind shipped with casrecon touches four files outside the tests, none in the engine
(``casrecon/estimation/engine``):

1. its module, ``casrecon/estimation/kinds/<kind>.py``: the kind (this file's ``SecondAntenna``) and
   how its settings make it for each fit (``MAKER``);
2. its reader and table parser, ``casrecon/io/<kind>.py`` (``parse_antenna``, ``AntennaSettings``),
   with its keys for the TOML reference;
3. its table's registration, one entry of ``SAMPLE_SENSORS`` in ``casrecon/io/sample_sensors.py``
   (``SENSOR``): ``io/problem.py`` and ``io/kinematic_problem.py`` read every registered table, and
   the TOML reference lists it;
4. its kind's registration, one entry of ``SAMPLE_KIND_MAKERS`` in
   ``casrecon/estimation/kinds/sample_registry.py``.

(``docs/problem-toml.md`` is then regenerated.)

The truth is problems/ees-drop-1's (its shipped synthetic IMU and GPS data and truth trajectory);
the antenna-2 samples are made here from the truth trajectory with a known bias and noise.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.analysis.kinematic_truth import decimated
from casrecon.estimation.kinds.sample_registry import SAMPLE_KIND_MAKERS, SampleKindMaker, kinematic_sample_kinds
from casrecon.estimation.kinds.samples import BodyState, SampleSet, air_velocity
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.estimation.sixdof.parameters import ParameterSpec
from casrecon.io.errors import InputError
from casrecon.io.kinematic_problem import load_kinematic
from casrecon.io.sample_sensors import SampleSensor
from casrecon.io.toml_fields import Fields, read_toml
from casrecon.io.truth_trajectory import read_truth_trajectory
from casrecon.physics.rotations import dcm_body_to_ned, dcm_body_to_ned_array
from casrecon.scenario import Scenario

#: Antenna 2's position on the vehicle (vehicle coordinates, as ``[gps] position_m``), m.
ANTENNA2_M = np.array([-0.55, 0.45, -0.20])
#: Its true constant bias (NED, m), prior 1-sigma and white noise 1-sigma (m).
BIAS_TRUE = np.array([0.40, -0.30, 0.25])
BIAS_PRIOR_M = 1.0
NOISE_M = 0.05
RATE_HZ = 5.0
AXES = ("n", "e", "d")


class SecondAntenna:
    """A second GPS antenna's positions: reference point + C(q) lever + bias (NED, m).

    Parameters
    ----------
    samples : SampleSet
        (N, 3) antenna positions, NED m, on the receiver's clock.
    lever_m : (3,) array
        The antenna minus the fit's reference point, in the fit's axes (6-DOF: from the centre of
        mass, body axes; kinematic: from the IMU, IMU axes), m.
    """

    name = "antenna2"
    columns = ("pos_n_m", "pos_e_m", "pos_d_m")

    def __init__(self, samples: SampleSet, lever_m: np.ndarray) -> None:
        self.samples = samples
        self.lever_m = np.asarray(lever_m, float)

    def parameters(self) -> tuple[ParameterSpec, ...]:
        return tuple(ParameterSpec(f"antenna2_bias_{a}_m", "antenna2", BIAS_PRIOR_M, BIAS_PRIOR_M, "m") for a in AXES)

    def predict(self, state: BodyState, theta: Mapping[str, ca.SX]) -> ca.SX:
        bias = ca.vertcat(*[theta[f"antenna2_bias_{a}_m"] for a in AXES])
        return state.position_ned_m + dcm_body_to_ned(state.quaternion) @ ca.DM(self.lever_m) + bias


def truth_samples(lever_body_m: np.ndarray, seed: int = 48) -> SampleSet:
    """Antenna-2 positions at RATE_HZ over ees-drop-1's flight from its truth trajectory (centre of
    mass, body to NED), stamped on the receiver's clock, with BIAS_TRUE and white noise."""
    tr = read_truth_trajectory(PROBLEMS / "ees-drop-1" / "data" / "trajectory.csv")
    t_rel, t_end = float(tr["time_unix_s"].iloc[0]), float(tr["flight_time_s"].iloc[-1])
    t = np.arange(0.1, t_end - 0.1, 1.0 / RATE_HZ)  # flight time, s (between the GPS fixes)
    pos = np.column_stack([np.interp(t, tr["flight_time_s"], tr[f"pos_{a}_m"]) for a in AXES])
    q = np.column_stack([np.interp(t, tr["flight_time_s"], tr[f"q{i}"]) for i in range(4)])
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    c = dcm_body_to_ned_array(q)
    rng = np.random.default_rng(seed)
    y = pos + c @ lever_body_m + BIAS_TRUE + NOISE_M * rng.normal(size=pos.shape)
    return SampleSet(t_rel + t, y, np.full(y.shape, NOISE_M), SecondAntenna.name)


@pytest.fixture(scope="module")
def scenario():
    return Scenario.load(PROBLEMS / "ees-drop-1")


@pytest.fixture(scope="module")
def samples(scenario):
    return truth_samples(scenario.config.vehicle.lever(ANTENNA2_M))


@dataclass(frozen=True)
class AntennaSettings:
    """The test antenna's ``[sensors.antenna2]`` (6-DOF) or ``[antenna2]`` (kinematic) table."""

    samples: SampleSet
    position_m: tuple | None  # on the vehicle (vehicle coordinates), 6-DOF problems
    lever_arm_m: tuple | None  # from the IMU, IMU axes, kinematic problems


def parse_antenna(t: Fields) -> AntennaSettings:
    """The table: ``file`` (CSV of time_unix_s, pos_n_m, pos_e_m, pos_d_m), ``noise_m``, and
    ``position_m`` or ``lever_arm_m``."""
    table = np.loadtxt(t.path_of("file", required=True), delimiter=",", skiprows=1, ndmin=2)
    noise = t.number("noise_m", NOISE_M, positive=True)
    settings = AntennaSettings(SampleSet(table[:, 0], table[:, 1:4], np.full((len(table), 3), noise), "antenna2"),
                               t.vector("position_m", 3), t.vector("lever_arm_m", 3))
    t.reject_unknown()
    return settings


#: The test antenna's registration, as a shipped kind would be registered.
SENSOR = SampleSensor("antenna2", parse_antenna)
MAKER = SampleKindMaker(
    sixdof=lambda s, cfg: SecondAntenna(s.samples, cfg.vehicle.lever(s.position_m)),
    kinematic=lambda s, cfg: SecondAntenna(s.samples, np.asarray(s.lever_arm_m, float)))


@pytest.fixture(scope="module")
def registered():
    """The test antenna registered for the module's tests."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("casrecon.io.sample_sensors.SAMPLE_SENSORS", (SENSOR,))
        mp.setitem(SAMPLE_KIND_MAKERS, "antenna2", MAKER)
        yield


@pytest.fixture(scope="module")
def samples_file(samples, tmp_path_factory):
    path = tmp_path_factory.mktemp("antenna2") / "antenna2.csv"
    np.savetxt(path, np.column_stack([samples.time_unix_s, samples.values]), delimiter=",", fmt="%.6f",
               header="time_unix_s,pos_n_m,pos_e_m,pos_d_m", comments="")
    return path


@pytest.fixture(scope="module")
def sixdof(scenario, registered, samples_file):
    """ees-drop-1 through the 6-DOF pipeline with ``[sensors.antenna2]`` added to its problem.toml,
    and the plain fit."""
    from casrecon.pipelines.sixdof import fit_sixdof

    document = read_toml(PROBLEMS / "ees-drop-1" / "problem.toml")
    data = copy.deepcopy(document.data)
    data["sensors"]["antenna2"] = {"file": str(samples_file), "position_m": ANTENNA2_M.tolist(), "noise_m": NOISE_M}
    configured = fit_sixdof(replace(document, data=data))
    assert configured.fit.measurements["antenna2"].values.shape[1] == 3
    return configured.fit, fit_drop(scenario)


def bias_z(result) -> np.ndarray:
    """(estimate - truth) / sigma of the three bias components."""
    est = [result.parameter(f"antenna2_bias_{a}_m") for a in AXES]
    return np.array([(v - b) / s for (v, s), b in zip(est, BIAS_TRUE)])


def check_against_fit_without(with_kind, without) -> None:
    """The problem's own parameters come first in the fit without the kind's order, none is less
    well determined with the kind, and each moves by what the added information explains: the
    difference of two nested estimates has variance sigma_without^2 - sigma_with^2 (the antenna's
    5 cm samples sharpen some parameters tenfold, so a fraction of the old sigma is no bound)."""
    assert with_kind.params.names[:without.params.n] == without.params.names
    for name in without.params.names:
        (v1, s1), (v0, s0) = with_kind.parameter(name), without.parameter(name)
        assert s1 <= 1.01 * s0, (name, s1, s0)
        spread = np.sqrt(max(s0 * s0 - s1 * s1, 0.01 * s0 * s0))
        assert abs(v1 - v0) < 3.0 * spread, (name, v1, v0, s1, s0)


def test_sixdof_fit_estimates_the_antenna2_bias(sixdof):
    """The 6-DOF fit: the kind's residual group at unit variance, its bias within 3 sigma of the
    truth, its residual table among the fit's, the other parameters consistent with the fit
    without it."""
    from casrecon.analysis.fit_products import other_kind_residuals

    with_kind, without = sixdof
    assert with_kind.converged and "antenna2" in with_kind.chi2 and "antenna2" not in without.chi2
    n = with_kind.n_measurements["antenna2"]
    assert n > 500
    assert with_kind.chi2["antenna2"] / n == pytest.approx(1.0, abs=4 * np.sqrt(2.0 / n))
    z = bias_z(with_kind)
    assert np.all(np.abs(z) < 3.0), z
    check_against_fit_without(with_kind, without)
    table = other_kind_residuals(with_kind)["antenna2"]
    assert list(table)[:2] == ["time_imu_s", "time_unix_s"] and table["pos_d_m_residual"].size * 3 == n


@pytest.fixture(scope="module")
def kinematic(scenario, samples):
    from casrecon.estimation.kinematic.fit import fit_kinematic
    from casrecon.estimation.kinematic.inputs import data_from_problem, options_from_problem

    cfg = scenario.config
    vehicle = cfg.vehicle
    # the 6-DOF problem's data are on the IMU clock: time 0 is the IMU clock's UTC at zero
    data = replace(decimated(data_from_problem(cfg), 5), time_ref_s=cfg.imu.clock_utc_at_zero.timestamp())
    lever_imu = np.asarray(vehicle.imu_to_body, float).T @ (ANTENNA2_M - np.asarray(vehicle.imu_position_m, float))
    options = options_from_problem(cfg)
    return fit_kinematic(data, options, sample_kinds=(SecondAntenna(samples, lever_imu),)), fit_kinematic(data, options)


def test_kinematic_fit_estimates_the_antenna2_bias(kinematic):
    """The kinematic fit of ees-drop-1's IMU at 100 Hz: the same."""
    with_kind, without = kinematic
    assert "antenna2" in with_kind.chi2 and "antenna2" not in without.chi2
    n = with_kind.n_measurements["antenna2"]
    assert n > 500
    assert with_kind.chi2["antenna2"] / n == pytest.approx(1.0, abs=4 * np.sqrt(2.0 / n))
    z = bias_z(with_kind)
    assert np.all(np.abs(z) < 3.0), z
    check_against_fit_without(with_kind, without)


def test_a_sample_set_refuses_bad_sigmas():
    with pytest.raises(ValueError, match="antenna2"):
        SampleSet(np.arange(3.0), np.zeros((3, 3)), np.zeros((3, 3)), "antenna2")


class Pitot:
    """Airspeed samples (m/s): a kind that needs the air velocity."""

    name = "pitot"
    columns = ("airspeed_mps",)

    def __init__(self, samples: SampleSet) -> None:
        self.samples = samples

    def parameters(self) -> tuple[ParameterSpec, ...]:
        return ()

    def predict(self, state: BodyState, theta: Mapping[str, ca.SX]) -> ca.SX:
        return ca.norm_2(air_velocity(state, self.name))


def test_a_kind_needing_the_air_velocity_refuses_the_kinematic_fit(scenario):
    from casrecon.estimation.kinematic.fit import fit_kinematic
    from casrecon.estimation.kinematic.inputs import data_from_problem, options_from_problem

    cfg = scenario.config
    data = replace(decimated(data_from_problem(cfg), 10), time_ref_s=cfg.imu.clock_utc_at_zero.timestamp())
    t = data.time_ref_s + np.arange(5.0, 30.0, 1.0)
    kind = Pitot(SampleSet(t, np.full((t.size, 1), 50.0), np.ones((t.size, 1)), "pitot"))
    with pytest.raises(ValueError, match="pitot.*air velocity.*kinematic"):
        fit_kinematic(data, options_from_problem(cfg), sample_kinds=(kind,))


def test_a_kind_needing_the_air_velocity_fits_in_the_sixdof_fit(scenario):
    """The airspeed kind in the 6-DOF fit, its samples the truth's airspeed with 0.3 m/s noise: the
    air velocity the flight model gives at the samples whitens them to unit variance."""
    tr = read_truth_trajectory(PROBLEMS / "ees-drop-1" / "data" / "trajectory.csv")
    t = np.arange(0.15, float(tr["flight_time_s"].iloc[-1]) - 0.1, 0.2)
    speed = np.interp(t, tr["flight_time_s"], tr["airspeed_mps"]) + 0.3 * np.random.default_rng(5).normal(size=t.size)
    kind = Pitot(SampleSet(float(tr["time_unix_s"].iloc[0]) + t, speed[:, None], np.full((t.size, 1), 0.3), "pitot"))
    result = fit_drop(scenario, sample_kinds=(kind,))
    n = result.n_measurements["pitot"]
    assert n > 150
    assert result.chi2["pitot"] / n == pytest.approx(1.0, abs=4 * np.sqrt(2.0 / n))


def test_a_kinematic_problem_configures_the_registered_kind(registered, samples_file):
    """``[antenna2]`` in a kinematic problem.toml makes the kind the kinematic pipeline fits."""
    document = read_toml(PROBLEMS / "realdata-fs2-chicago-kinematic" / "problem.toml")
    data = copy.deepcopy(document.data)
    data["antenna2"] = {"file": str(samples_file), "lever_arm_m": [0.1, 0.2, 0.3]}
    (kind,) = kinematic_sample_kinds(load_kinematic(replace(document, data=data)))
    assert isinstance(kind, SecondAntenna) and np.allclose(kind.lever_m, [0.1, 0.2, 0.3])
    data["antenna2"]["unknown_key"] = 1.0
    with pytest.raises(InputError, match="unknown_key"):
        load_kinematic(replace(document, data=data))
