"""The kinematic fit's aliased-stretch rule (issue 50, casrecon/estimation/kinematic/imu_record.py): where
the rate changes between consecutive samples by more than MAX_TURN_DIFFERENCE_RAD of turn over the
step, the samples do not resolve the rotation; such steps less than ALIASED_JOIN_S apart make one
stretch, whose samples keep their values but get the saturated-sample noise, and a note names them.
On a synthetic 13 Hz record: a smooth fast spin (a skydiver's exit) is not a stretch, a rate that
jumps about between samples (an opening shock) is."""

from __future__ import annotations

import numpy as np

from casrecon.estimation.kinematic.data import KinematicData, KinematicOptions
from casrecon.estimation.kinematic.imu_record import (
    ALIASED_JOIN_S,
    MAX_TURN_DIFFERENCE_RAD,
    ImuRecord,
    aliased_samples,
    aliased_stretches,
)
from casrecon.io.imu import ImuCsvSpec, ImuLog

DT = 1.0 / 13.0


def record(bursts: tuple[tuple[float, float], ...] = ((20.0, 22.0),)) -> tuple[np.ndarray, np.ndarray]:
    """40 s at 13 Hz: a spin about z ramping smoothly to 250 deg/s and back (6 to 14 s: 19 deg per
    sample, 1.5 deg of turn between consecutive samples), and in each burst (start, end) rates that
    alternate between +-300 deg/s about x and y from one sample to the next (the rate the samples
    show reverses every step: 2 x 300 deg/s x 77 ms = 46 deg of turn difference)."""
    t = np.arange(0.0, 40.0, DT)
    gyro = np.zeros((t.size, 3))
    gyro[:, 2] = np.radians(250.0) * np.clip(np.minimum(t - 6.0, 14.0 - t) / 2.0, 0.0, 1.0)
    sign = np.where(np.arange(t.size) % 2 == 0, 1.0, -1.0)
    for a, b in bursts:
        inside = (t >= a) & (t < b)
        gyro[inside, 0] = np.radians(300.0) * sign[inside]
        gyro[inside, 1] = -np.radians(300.0) * sign[inside]
    return t, gyro


def test_a_smooth_fast_spin_is_resolved_and_a_rate_jumping_between_samples_is_not():
    t, gyro = record()
    assert np.degrees(np.max(np.linalg.norm(gyro, axis=1) * DT)) > 19.0  # the spin turns fast ...
    assert aliased_stretches(t, gyro * [0.0, 0.0, 1.0]) == []  # ... but smoothly: no stretch
    stretches = aliased_stretches(t, gyro)
    assert len(stretches) == 1
    a, b = stretches[0]
    burst = np.flatnonzero((t >= 20.0) & (t < 22.0))
    # the burst's samples and the clean samples on either side whose step into it jumps
    assert a == burst[0] - 1 and b == burst[-1] + 1, (a, b, burst[[0, -1]])


def test_steps_just_below_the_limit_are_no_stretch_and_close_stretches_join():
    t, gyro = record()
    scale = 0.99 * MAX_TURN_DIFFERENCE_RAD / np.max(np.linalg.norm(np.diff(gyro, axis=0), axis=1) * DT)
    assert aliased_stretches(t, gyro * scale) == []
    near = record(((20.0, 21.0), (21.0 + 0.8 * ALIASED_JOIN_S, 22.0)))
    far = record(((20.0, 21.0), (21.0 + 3 * ALIASED_JOIN_S, 23.0)))
    assert len(aliased_stretches(*near)) == 1
    assert len(aliased_stretches(*far)) == 2


def test_aliased_samples_keep_their_values_get_the_saturated_noise_and_a_note():
    t0 = 1726601000.0
    t, gyro = record()
    accel = np.tile([0.0, 0.0, -9.81], (t.size, 1))
    flags = np.zeros((t.size, 3), bool)
    log = ImuLog("SENSOR.CSV", t + t0, accel, gyro, flags, flags, np.arange(t.size) * 3 + 10)
    spec = ImuCsvSpec("time", ("ax", "ay", "az"), ("wx", "wy", "wz"), accel_unit="g", gyro_unit="deg/s")
    aliased, notes = aliased_samples(ImuRecord(log, spec), t0 + 5.0, t0 + 30.0)
    inside = (t >= 5.0) & (t <= 30.0)
    assert aliased.size == inside.sum()
    a, b = aliased_stretches(t, gyro)[0]
    expected = np.zeros(t.size, bool)
    expected[a:b + 1] = True
    np.testing.assert_array_equal(aliased, expected[inside])
    (note,) = notes
    assert note.startswith(f"{b - a + 1} IMU samples in 1 stretch whose rotation the sampling does not resolve")
    assert f"t = {t0 + t[a]:.3f} to {t0 + t[b]:.3f} s (lines {a * 3 + 10} to {b * 3 + 10})" in note, note
    # the fit's data: values kept, gyros and accelerometers weighted with the saturated-sample noise
    data = KinematicData(t[inside], gyro[inside], accel[inside], ~flags[inside], ~flags[inside], t[:3],
                         np.zeros((3, 6)), np.ones((3, 6)), (5.0, 30.0), imu_aliased=aliased)
    options = KinematicOptions(gyro_noise_radps=0.01, accel_noise_mps2=0.1, gyro_bias_sigma_radps=0.01,
                               accel_bias_sigma_mps2=0.1)
    gyro_sigma, accel_sigma = data.noise_sigmas(options)
    np.testing.assert_array_equal(gyro_sigma[aliased], options.saturated_gyro_sigma_radps)
    np.testing.assert_array_equal(accel_sigma[aliased], options.saturated_accel_sigma_mps2)
    np.testing.assert_array_equal(gyro_sigma[~aliased], 0.01)
    np.testing.assert_array_equal(data.bridged()[0], gyro[inside])
