"""Evaluate a CasADi ``Function`` on numpy arrays into numpy arrays, without ``casadi.DM``.

Calling a ``Function`` with numpy inputs converts them to ``DM`` and returns ``DM`` results, which
numpy then copies element by element (about 0.1 us an element: 0.15 s for the node outputs and
their Jacobians of a 40 s drop). :func:`numpy_call` uses ``Function.buffer()`` instead: CasADi reads
the inputs from and writes the outputs into numpy's own memory.
"""

from __future__ import annotations

import casadi as ca
import numpy as np


class BufferedFunction:
    """A CasADi ``Function`` evaluated on numpy arrays into numpy arrays through one
    ``Function.buffer()`` made once (making one allocates the function's work memory: 4 ms for
    a fit's block evaluator), for functions called many times. Not for concurrent use by threads;
    picklable (the buffer is made again).

    Parameters
    ----------
    function : casadi.Function
        Every input and output dense (else use :func:`numpy_call`, which falls back to ``DM``).
    """

    def __init__(self, function: ca.Function) -> None:
        if not is_dense(function):
            raise ValueError(f"{function.name()}: BufferedFunction needs dense inputs and outputs")
        self.function = function
        self.buffer, self.evaluate = function.buffer()

    def __getstate__(self) -> dict:
        return {"function": self.function}  # a buffer is process memory: made again on unpickling

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["function"])

    def __call__(self, *inputs) -> list[np.ndarray]:
        """``function(*inputs)`` as float arrays (see :func:`numpy_call`)."""
        function = self.function
        check_input_count(function, inputs)
        columns = [column_major(function, i, x) for i, x in enumerate(inputs)]  # alive until evaluated
        outputs = [np.empty((function.size2_out(k), function.size1_out(k))) for k in range(function.n_out())]
        for i, x in enumerate(columns):
            self.buffer.set_arg(i, memoryview(x))
        for k, out in enumerate(outputs):
            self.buffer.set_res(k, memoryview(out))
        self.evaluate()
        return [out.T for out in outputs]


def check_input_count(function: ca.Function, inputs: tuple) -> None:
    """ValueError unless ``inputs`` has one entry per input of ``function``."""
    if len(inputs) != function.n_in():
        raise ValueError(f"{function.name()}: {len(inputs)} inputs given, it takes {function.n_in()}")


def is_dense(function: ca.Function) -> bool:
    """Whether every input and output of ``function`` is dense."""
    return all(function.sparsity_in(i).is_dense() for i in range(function.n_in())) and all(
        function.sparsity_out(i).is_dense() for i in range(function.n_out()))


def column_major(function: ca.Function, i: int, x) -> np.ndarray:
    """Input ``i`` of ``function`` as a contiguous float vector in CasADi's column-major order;
    ValueError when its size (or, for a matrix input, its shape) is not the input's."""
    values = np.asarray(x, float)
    n1, n2 = function.size1_in(i), function.size2_in(i)
    if values.size != n1 * n2:
        raise ValueError(f"{function.name()}: input {function.name_in(i)} has {values.size} elements, "
                         f"expected {n1} x {n2}")
    if n1 > 1 and n2 > 1:  # a matrix: its numpy shape must be the input's
        if values.shape != (n1, n2):
            raise ValueError(f"{function.name()}: input {function.name_in(i)} has shape {values.shape}, "
                             f"expected ({n1}, {n2})")
        values = values.T  # numpy's row-major copy of the transpose is CasADi's column-major order
    return np.ascontiguousarray(values).ravel()


def numpy_call(function: ca.Function, *inputs) -> list[np.ndarray]:
    """``function(*inputs)`` as a list of float arrays, one per output, each of the output's shape
    (``size1`` x ``size2``).

    Parameters
    ----------
    function : casadi.Function
        Any function; dense inputs and outputs are passed through CasADi's buffers, a function
        with a sparse input or output is called the ordinary way.
    *inputs : array_like
        One per input: a matrix input of exactly its shape; a scalar or a vector input of the right
        number of elements, flat or as a row or column.

    Returns
    -------
    list of ndarray
        Output ``k`` as an (size1, size2) array (a new array, not a view of CasADi memory).

    Raises
    ------
    ValueError
        An input whose number of elements (or, for a matrix input, shape) differs from the
        function's input.
    """
    if not is_dense(function):
        check_input_count(function, inputs)
        return [np.asarray(ca.DM(out), float) for out in function.call([ca.DM(x) for x in inputs])]
    return BufferedFunction(function)(*inputs)


def numpy_rows(function: ca.Function, *rows: np.ndarray) -> np.ndarray:
    """``function``'s first output at each row of ``rows`` (each an (n, m_i) array, one per input
    of ``function``, whose inputs are column vectors), as an (n, k) array: the function mapped over
    the n rows and evaluated by :func:`numpy_call`."""
    mapped = function.map(np.shape(rows[0])[0])
    return numpy_call(mapped, *(np.asarray(r, float).T for r in rows))[0].T
