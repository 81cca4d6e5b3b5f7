"""Anti-alias filtering and decimation of a raw IMU log (for example 50 kHz to 500 Hz).

:func:`decimate_imu` filters every channel with one linear-phase FIR low-pass and keeps every
``q``-th sample, zero phase (the filter delay is removed, so a decimated sample is centred on
its raw sample ``k q``), polyphase (``scipy.signal.resample_poly``: the filter is evaluated
only at the kept samples, so 2 000 000 raw samples x 6 channels decimate in about a second).

Filter (Kaiser window, ``scipy.signal.firwin``): pass band to ``PASS_FRACTION`` = 0.8 of the
new Nyquist frequency (ripple well under 1 %), stop band from the new Nyquist frequency on,
attenuated by at least ``STOP_ATTENUATION_DB`` = 60 dB, so nothing above the new Nyquist
aliases into the result by more than 0.1 % of its amplitude. Between 0.8 and 1.0 of the new
Nyquist the response rolls off: use the decimated log only up to 0.8 of its Nyquist.

Saturation rule: a decimated sample is flagged saturated on an axis when the saturated raw
samples feeding it carry at least ``SATURATION_WEIGHT`` = 0.1 % of the filter's total
absolute weight (``sum |h|`` over the saturated taps / ``sum |h|``). A clipped raw sample's
unknown lost part is then at most about full scale times that weight, 0.1 % of full scale,
well below the 2 % of full scale accuracy of the EES drops' IMU; any more and the
output is flagged. In practice one saturated raw sample flags the output samples whose main
lobe reaches it, and a saturated burst flags its span plus about half the filter length.

Edges: the signal is extended by a straight line fitted at each end (``padtype="line"``); the
first and last ``len(h) // (2 q)`` decimated samples still carry some edge transient.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy import signal

from casrecon.io.errors import InputError, plain_repr
from casrecon.io.imu import ImuLog

PASS_FRACTION = 0.8
STOP_ATTENUATION_DB = 60.0
SATURATION_WEIGHT = 1e-3
#: Largest relative deviation of a sample interval from the median one accepted as uniform.
UNIFORM_RTOL = 0.01
#: Largest relative mismatch between ``target_rate_hz`` and ``rate / factor``.
RATE_RTOL = 0.01


def antialias_fir(factor: int) -> np.ndarray:
    """The low-pass FIR used to decimate by ``factor`` (odd length, unit DC gain).

    Parameters
    ----------
    factor : int
        Decimation factor q >= 2.

    Returns
    -------
    numpy.ndarray
        Filter taps, symmetric (linear phase).
    """
    width = (1.0 - PASS_FRACTION) / factor  # transition width, as a fraction of raw Nyquist
    numtaps, beta = signal.kaiserord(STOP_ATTENUATION_DB, width)
    numtaps |= 1
    cutoff = (1.0 + PASS_FRACTION) / 2.0 / factor
    return signal.firwin(numtaps, cutoff, window=("kaiser", beta))


def decimate_imu(log: ImuLog, factor: int | None = None, *,
                 target_rate_hz: float | None = None) -> ImuLog:
    """Anti-alias filter and decimate every channel of an IMU log.

    Parameters
    ----------
    log : ImuLog
        Uniformly sampled raw log.
    factor : int, optional
        Keep every ``factor``-th sample (>= 2). Give this or ``target_rate_hz``.
    target_rate_hz : float, optional
        Wanted output rate; the factor is ``round(rate / target_rate_hz)`` and must give the
        target within 1 %.

    Returns
    -------
    ImuLog
        Same path; time of raw samples ``0, q, 2q, ...``; filtered accelerometer and gyro;
        saturation flags by the rule of the module docstring.

    Raises
    ------
    ValueError
        Neither or both of ``factor`` and ``target_rate_hz``, a factor below 2, or a target
        rate that no integer factor reaches within 1 %.
    InputError
        If the log is not uniformly sampled (a gap or a jitter over 1 % of the median step:
        the FIR assumes uniform samples; the message gives the time of the first bad step)
        or has too few samples for the filter.
    """
    if (factor is None) == (target_rate_hz is None):
        raise ValueError("give exactly one of factor and target_rate_hz")
    t = log.time_s
    if t.size < 2:
        raise InputError(log.path, f"too few samples ({t.size}) to decimate")
    step = np.diff(t)
    dt = float(np.median(step))
    off = np.abs(step - dt) > UNIFORM_RTOL * dt
    if off.any():
        k = int(np.argmax(off))
        raise InputError(log.path, f"not uniformly sampled: step {step[k]:.6g} s at t = "
                         f"{t[k]:.6f} s against the median {dt:.6g} s; decimation needs "
                         "uniform samples (fill or split at gaps first)")
    if target_rate_hz is not None:
        rate = 1.0 / dt
        if not target_rate_hz > 0:
            raise ValueError(f"target_rate_hz must be positive, got {target_rate_hz}")
        factor = int(round(rate / target_rate_hz))
        if factor < 1 or abs(rate / max(factor, 1) - target_rate_hz) > RATE_RTOL * target_rate_hz:
            raise ValueError(f"no integer factor takes {rate:.6g} Hz to {target_rate_hz:g} Hz "
                             "within 1 %")
    if not isinstance(factor, int | np.integer) or factor < 2:
        raise ValueError(f"factor must be an integer >= 2, got {plain_repr(factor)}")
    factor = int(factor)
    h = antialias_fir(factor)
    if t.size < h.size:
        raise InputError(log.path, f"too few samples ({t.size}) to decimate by {factor}: the "
                         f"anti-alias filter is {h.size} samples long")
    weight = np.abs(h) / np.abs(h).sum()

    def filt(x: np.ndarray) -> np.ndarray:
        return np.column_stack([signal.resample_poly(x[:, k], 1, factor, window=h,
                                                     padtype="line") for k in range(3)])

    def flags(sat: np.ndarray) -> np.ndarray:
        out = np.zeros(((t.size + factor - 1) // factor, 3), dtype=bool)
        for k in range(3):
            if sat[:, k].any():
                w = signal.resample_poly(sat[:, k].astype(np.float64), 1, factor,
                                         window=weight, padtype="constant")
                out[:, k] = w >= SATURATION_WEIGHT * (1.0 - 1e-9)
        return out

    return replace(log, time_s=t[::factor].copy(), accel_mps2=filt(log.accel_mps2),
                   gyro_radps=filt(log.gyro_radps), accel_saturated=flags(log.accel_saturated),
                   gyro_saturated=flags(log.gyro_saturated))
