"""casrecon.physics.numpy_call: CasADi functions on numpy arrays through Function.buffer()."""

from __future__ import annotations

import pickle

import casadi as ca
import numpy as np
import pytest

from casrecon.physics.numpy_call import BufferedFunction, numpy_call, numpy_rows


def example() -> ca.Function:
    x, m = ca.SX.sym("x", 3), ca.SX.sym("m", 2, 4)
    return ca.Function("f", [x, m], [x * 2, ca.mtimes(m.T, m), ca.sumsqr(x)], ["x", "m"], ["a", "b", "c"])


def test_equals_casadis_own_call_for_vectors_matrices_and_maps():
    rng = np.random.default_rng(0)
    f = example()
    for fn, x, m in [(f, rng.normal(size=3), rng.normal(size=(2, 4))),
                     (f.map(50, "thread", 2), rng.normal(size=(3, 50)), rng.normal(size=(2, 200)))]:
        got, want = numpy_call(fn, x, m), fn(x, m)
        for g, w in zip(got, want):
            assert g.shape == w.shape
            np.testing.assert_array_equal(g, np.asarray(w))


def test_a_buffered_function_is_reusable_and_picklable():
    f = BufferedFunction(example())
    first = f(np.arange(3.0), np.ones((2, 4)))
    second = f(np.arange(3.0) + 1, np.ones((2, 4)))
    assert first[2][0, 0] == 5.0 and second[2][0, 0] == 14.0  # the first result was not overwritten
    copy = pickle.loads(pickle.dumps(f))
    np.testing.assert_array_equal(copy(np.arange(3.0), np.ones((2, 4)))[1], first[1])


def test_a_sparse_output_falls_back_to_dm():
    x = ca.SX.sym("x", 3)
    f = ca.Function("g", [x], [ca.diag(x)])
    np.testing.assert_array_equal(numpy_call(f, [1.0, 2.0, 3.0])[0], np.diag([1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match="dense"):
        BufferedFunction(f)


def test_wrong_inputs_are_refused_with_the_inputs_name():
    f = example()
    with pytest.raises(ValueError, match="input x has 4 elements, expected 3 x 1"):
        numpy_call(f, np.zeros(4), np.zeros((2, 4)))
    with pytest.raises(ValueError, match=r"input m has shape \(4, 2\), expected \(2, 4\)"):
        numpy_call(f, np.zeros(3), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="1 inputs given, it takes 2"):
        numpy_call(f, np.zeros(3))


def test_numpy_rows_evaluates_the_function_at_each_row():
    x, y = ca.SX.sym("x", 3), ca.SX.sym("y", 2)
    f = ca.Function("f", [x, y], [ca.vertcat(x[0] * y[1], ca.sumsqr(x) + y[0])])
    rng = np.random.default_rng(2)
    xs, ys = rng.normal(size=(5, 3)), rng.normal(size=(5, 2))
    out = numpy_rows(f, xs, ys)
    want = np.column_stack([xs[:, 0] * ys[:, 1], np.sum(xs ** 2, axis=1) + ys[:, 0]])
    assert out.shape == (5, 2)
    np.testing.assert_allclose(out, want, rtol=1e-14)
