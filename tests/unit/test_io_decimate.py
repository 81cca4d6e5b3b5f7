"""Anti-alias decimation of IMU logs: pass band kept, stop band attenuated, zero phase,
saturation propagation, refusals."""

from __future__ import annotations

import numpy as np
import pytest

from casrecon.io.decimate import SATURATION_WEIGHT, antialias_fir, decimate_imu
from casrecon.io.errors import InputError
from casrecon.io.imu import ImuLog

FS = 50_000.0


def sine_log(freq_hz: float, n: int = 200_000, sat: np.ndarray | None = None) -> ImuLog:
    t = 3.0 + np.arange(n) / FS
    x = np.sin(2 * np.pi * freq_hz * t)
    v = np.column_stack([x, 2 * x, -x])
    flags = np.zeros((n, 3), dtype=bool) if sat is None else sat
    return ImuLog("raw.csv", t, v + 9.8, v, flags, flags.copy())


def amplitude(log: ImuLog, freq_hz: float, col: int = 0) -> float:
    """Least-squares sine amplitude away from the edges."""
    t, y = log.time_s[50:-50], log.gyro_radps[50:-50, col]
    A = np.column_stack([np.sin(2 * np.pi * freq_hz * t), np.cos(2 * np.pi * freq_hz * t),
                         np.ones_like(t)])
    c = np.linalg.lstsq(A, y, rcond=None)[0]
    return float(np.hypot(c[0], c[1]))


@pytest.mark.parametrize("freq", [5.0, 50.0, 150.0, 195.0])
def test_pass_band_keeps_amplitude_and_phase(freq):
    d = decimate_imu(sine_log(freq), target_rate_hz=500.0)
    assert d.n == 2000 and d.time_s[1] - d.time_s[0] == pytest.approx(0.002)
    for col, amp in ((0, 1.0), (1, 2.0), (2, 1.0)):
        assert amplitude(d, freq, col) == pytest.approx(amp, rel=0.01)
    ref = np.sin(2 * np.pi * freq * d.time_s[50:-50])
    np.testing.assert_allclose(d.gyro_radps[50:-50, 0], ref, atol=0.01)  # zero phase
    np.testing.assert_allclose(d.accel_mps2[50:-50, 0], ref + 9.8, atol=0.01)


@pytest.mark.parametrize("freq", [250.0, 300.0, 1000.0, 4321.0])
def test_above_new_nyquist_attenuated_40_db(freq):
    d = decimate_imu(sine_log(freq), 100)
    assert amplitude(d, freq) < 0.01  # also the alias frequency: check the raw RMS
    assert np.sqrt(2 * np.mean(d.gyro_radps[50:-50, 0] ** 2)) < 0.01


def test_saturation_propagates_by_weight():
    n = 200_000
    sat = np.zeros((n, 3), dtype=bool)
    sat[100_000, 0] = True
    sat[150_000:150_500, 2] = True
    d = decimate_imu(sine_log(10.0, n, sat), 100)
    assert list(np.flatnonzero(d.gyro_saturated[:, 0])) == [1000]
    assert not d.gyro_saturated[:, 1].any()
    idx = np.flatnonzero(d.gyro_saturated[:, 2])
    assert idx[0] <= 1500 and idx[-1] >= 1504 and np.all(np.diff(idx) == 1)
    h = np.abs(antialias_fir(100))
    w = h / h.sum()
    # flagged span = samples where the burst's weight reaches SATURATION_WEIGHT
    assert idx.size < 5 + w.size // 100
    np.testing.assert_array_equal(d.accel_saturated, d.gyro_saturated)
    assert SATURATION_WEIGHT == 1e-3


def test_refusals():
    log = sine_log(10.0, 20_000)
    with pytest.raises(ValueError):
        decimate_imu(log)
    with pytest.raises(ValueError):
        decimate_imu(log, 10, target_rate_hz=5000.0)
    with pytest.raises(ValueError, match="no integer factor"):
        decimate_imu(log, target_rate_hz=3000.0)
    with pytest.raises(ValueError):
        decimate_imu(log, 1)
    t = log.time_s.copy()
    t[5000:] += 0.01
    gap = ImuLog("gap.csv", t, log.accel_mps2, log.gyro_radps, log.accel_saturated,
                 log.gyro_saturated)
    with pytest.raises(InputError, match="gap.csv: not uniformly sampled"):
        decimate_imu(gap, 10)
    with pytest.raises(InputError, match="too few samples"):
        decimate_imu(sine_log(10.0, 500), 100)
