"""casrecon.estimation.numerics.savgol gives scipy.signal's Savitzky-Golay numbers bit for bit, without importing it."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy import signal

from casrecon.estimation.numerics.savgol import savgol_coeffs, savgol_filter

CASES = [(51, 3, 1, 0.002), (51, 3, 0, 0.002), (21, 2, 1, 0.01), (7, 3, 2, 0.5), (101, 3, 1, 0.0025)]


@pytest.mark.parametrize(("window", "order", "deriv", "delta"), CASES)
def test_coefficients_are_scipys(window, order, deriv, delta):
    for pos in (None, 0, 3, window // 2, window - 1):
        for use in ("conv", "dot"):
            ours = savgol_coeffs(window, order, deriv, delta, pos=pos, use=use)
            assert np.array_equal(ours, signal.savgol_coeffs(window, order, deriv=deriv, delta=delta, pos=pos,
                                                             use=use))


@pytest.mark.parametrize(("window", "order", "deriv", "delta"), CASES)
def test_filter_is_scipys_bit_for_bit(window, order, deriv, delta):
    rng = np.random.default_rng(window + 7 * deriv)
    for scale in (1e-3, 1.0, 1e3):
        x = rng.normal(size=(2000, 3)) * scale
        ref = signal.savgol_filter(x, window, order, deriv=deriv, delta=delta, axis=0)
        assert np.array_equal(savgol_filter(x, window, order, deriv, delta), ref)
        rows = np.r_[0, window // 2 - 1, window // 2, rng.integers(0, 2000, 40), 2000 - window // 2 - 1, 1999]
        assert np.array_equal(savgol_filter(x, window, order, deriv, delta, rows=rows), ref[rows])


def test_scipy_signal_is_not_imported():
    code = ("import sys, numpy as np; from casrecon.estimation.numerics.savgol import savgol_filter; "
            "savgol_filter(np.arange(300.0) ** 2, 51, 3, 1, 0.002, rows=np.arange(300)); "
            "print('scipy.signal' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    assert out.strip() == "False"


def test_bad_window_is_refused():
    with pytest.raises(ValueError):
        savgol_filter(np.zeros(10), 11, 3)
    with pytest.raises(ValueError):
        savgol_filter(np.zeros(100), 10, 3)
