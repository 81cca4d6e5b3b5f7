"""Evaluate mapped block functions into numpy arrays without going through ``casadi.DM``.

Turning a ``DM`` result into a numpy array copies it element by element in Python (about 0.1 us
an element; a 6-DOF fit's derivative outputs hold about two million); building a sparse ``DM`` from
numpy values costs as much. Both are avoided here:

- :class:`BlockEvaluator` is one MX function ``z -> outputs of every set's mapped function at its
  blocks' local z``, evaluated through ``Function.buffer()``
  (:class:`~casrecon.physics.numpy_call.BufferedFunction`): CasADi reads z from and writes every output
  into numpy's memory. The gather of each block's local variables from z is done by CasADi too.
  (An earlier version copied the outputs out with a sink callback; building the call of that
  callback on the outputs' million-entry patterns cost 0.26 s per NLP.)
- :class:`BufferCallback` is the base of callbacks that write their results straight into
  CasADi's output memory (the solver's derivatives, :mod:`.solve`).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.physics.numpy_call import BufferedFunction


class BufferCallback(ca.Callback):
    """A CasADi callback evaluated through raw buffers: subclasses implement
    :meth:`fill` ``(inputs, outputs)`` on numpy views (flat nonzeros, column-major)."""

    #: The exception :meth:`fill` raised last, if any: CasADi passes it on only as the text of a
    #: RuntimeError, so a caller that needs the exception itself (an interrupt) takes it from here.
    raised: BaseException | None = None

    def has_eval_buffer(self) -> bool:
        return True

    def eval_buffer(self, arg, res) -> int:
        # CasADi passes None for an input that is all zeros and for an output nobody asked for
        inputs = [np.zeros(self.sparsity_in(i).nnz()) if a is None else np.frombuffer(a, dtype=np.float64)
                  for i, a in enumerate(arg)]
        outputs = [np.zeros(self.sparsity_out(i).nnz()) if r is None else np.frombuffer(r, dtype=np.float64)
                   for i, r in enumerate(res)]
        try:
            self.fill(inputs, outputs)
        except BaseException as err:
            self.raised = err
            raise
        return 0

    def fill(self, inputs: list[np.ndarray], outputs: list[np.ndarray]) -> None:
        raise NotImplementedError


class BlockEvaluator:
    """All sets' mapped functions at one z, returned as numpy arrays.

    Parameters
    ----------
    functions : list of Function
        Per set, the mapped function ``(local, *data) -> outputs`` (every output dense).
    cols : list of int arrays (n_blocks, n_local)
        Per set, the global z index of each block's local variables.
    data : list of lists
        Per set, the data inputs (constant).
    n_z : int
    """

    def __init__(self, functions: list[ca.Function], cols: list[np.ndarray], data: list[list], n_z: int) -> None:
        z = ca.MX.sym("z", n_z)
        outs, self.n_outputs = [], []
        for fn, c, d in zip(functions, cols, data):
            c = np.asarray(c, np.int64)
            local = ca.reshape(z[c.ravel().tolist()], c.shape[1], c.shape[0])
            res = fn.call([local, *d])
            for o in res:
                if not o.sparsity().is_dense():
                    raise ValueError(f"{fn.name()}: block function outputs must be dense")
            outs.extend(res)
            self.n_outputs.append(len(res))
        self.function = BufferedFunction(ca.Function("block_evaluator", [z], outs))

    def __call__(self, z: np.ndarray) -> list[list[np.ndarray]]:
        """Per set, its outputs at ``z`` as arrays of shape (n_blocks, n_rows) (one row per block)."""
        arrays = iter(self.function(z))
        return [[next(arrays).T for _ in range(n)] for n in self.n_outputs]
