"""A statistical stopping test for the fit: the Gauss-Newton decrement.

Ipopt stops on the size of the dual infeasibility. On long, fine meshes the reduced Hessian's
condition number is about 1e10 and the last digits of that infeasibility are round-off: an
estimator Monte Carlo of ees-drop-3 (26 ms mesh) saw 20 of 50 fits reach Ipopt's 200-iteration
limit while sitting at the optimum, trading 1e-7 of defect violation for 0.1 of objective.

What an estimate needs is different and measurable: a full constrained Gauss-Newton step from the
current iterate would lower chi-square by

    delta = g^T Z (Z^T H Z)^-1 Z^T g,     g = grad(1/2 |r|^2),  H = J^T J,  A Z = 0,

and the iterate is then sqrt(delta) standard deviations (in the Mahalanobis metric of the
estimate's own covariance) from the optimum of the linearised problem. When the defects are
satisfied (max |c| <= FEASIBILITY_TOL, scaled units) and delta <= DECREMENT_TOL the fit has
converged whatever Ipopt's dual infeasibility says. :class:`DecrementStop` applies the test at
Ipopt's iterates (as its iteration callback; variables on a bound are held, as in Ipopt's active
set) and :func:`gauss_newton_decrement` once more after it returns.

NLPs with latent process values (``Nlp.latent``: gusts, model-error states at every node) have
thousands of null-space directions, so Z is never formed for them: the same decrement is -g^T dz
of the step from the KKT system [[H, A^T], [A, 0]] [dz; lambda] = [-g; 0], factorised as a
:class:`.bordered_kkt.BorderedKkt` (0.06 s on a 4 s gust window), made only once the objective
has stopped moving. Before, Ipopt's own test alone decided for them (on a 4 s gust window of the
calibration study the test now stops Ipopt after 10 iterations instead of 12).
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import casadi as ca
import numpy as np
from scipy.linalg import null_space

from casrecon.estimation.engine.bordered_kkt import BorderedKkt
from casrecon.estimation.engine.covariance import fisher_and_jacobian, kkt_matrix, reduced_system_at
from casrecon.estimation.engine.nlp import Nlp
from casrecon.progress import heartbeat

LOG = logging.getLogger(__name__)

#: Largest predicted chi-square decrease of a full Gauss-Newton step at a converged iterate: the
#: iterate is then within sqrt(1e-3) = 0.03 sigma of the optimum.
DECREMENT_TOL = 1e-3
#: Largest defect or quaternion-norm violation (scaled units) at which the test is made.
FEASIBILITY_TOL = 1e-8
#: The test is made only once the objective has stopped moving: relative change between
#: successive iterates below this (it costs about one Ipopt iteration on a 45 s drop).
OBJECTIVE_CHANGE = 1e-6


#: (level, label) of the iteration lines of the solves started now (see :func:`iteration_logging`).
_ITERATION_LOG: ContextVar[tuple[int, str]] = ContextVar("casrecon_iteration_log", default=(logging.INFO, ""))


@contextmanager
def iteration_logging(level: int | None = None, label: str | None = None) -> Iterator[None]:
    """Within the ``with`` block, fits log their Ipopt iteration lines at ``level`` (a
    :mod:`logging` level; INFO outside any block), each prefixed with ``label + ": "`` (none
    outside any block); None keeps the enclosing block's. E.g. a profile likelihood's refits log
    theirs at DEBUG and one INFO line per grid point; a fit solved twice labels its two runs."""
    outer_level, outer_label = _ITERATION_LOG.get()
    token = _ITERATION_LOG.set((outer_level if level is None else level, outer_label if label is None else label))
    try:
        yield
    finally:
        _ITERATION_LOG.reset(token)


def iteration_log_settings() -> tuple[int, str]:
    """(logging level, label) of the iteration lines of a solve started now (see
    :func:`iteration_logging`)."""
    return _ITERATION_LOG.get()


def log_iteration(level: int, label: str, iteration: int, chi2: float, violation: float) -> None:
    """Log one iterate's line ``iteration K: chi-square X, constraint violation Y`` at ``level``
    (logger ``casrecon.estimation.engine.convergence``), prefixed with ``label + ": "`` if any."""
    if LOG.isEnabledFor(level):
        LOG.log(level, "%siteration %d: chi-square %.6g, constraint violation %.2g",
                f"{label}: " if label else "", iteration, chi2, violation)


def nested_label(text: str) -> str:
    """``text`` after the label of the enclosing :func:`iteration_logging` block, if any (``"case 3,
    fit 1 of up to 4"``): a label for a block inside it."""
    outer = _ITERATION_LOG.get()[1]
    return f"{outer}, {text}" if outer else text


def log_stage(text: str) -> None:
    """Log that the fit enters the stage ``text`` (e.g. ``"covariance"``), as ``label: text`` at the
    level and with the label of the enclosing :func:`iteration_logging` block (INFO and no label
    outside any block), so that a long step between iteration lines is named in the log."""
    level, label = _ITERATION_LOG.get()
    if LOG.isEnabledFor(level):
        LOG.log(level, "%s%s", f"{label}: " if label else "", text)


@contextmanager
def fit_stage(text: str, announce: bool = True) -> Iterator[None]:
    """Log the stage ``text`` (:func:`log_stage`; not with ``announce`` False) and, while the block
    runs, that it is still running whenever :data:`casrecon.progress.HEARTBEAT_S` seconds pass
    without a line (:func:`casrecon.progress.heartbeat`), at the level and with the label of the
    enclosing :func:`iteration_logging` block. ``announce=False`` suits a stage that may end in a
    refusal of the inputs, whose one error line should stand alone: it speaks only if it runs long."""
    level, label = _ITERATION_LOG.get()
    if announce:
        log_stage(text)
    with heartbeat(LOG, level, f"{label}: {text}" if label else text):
        yield


def at_bounds(z: np.ndarray, bounds: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    """Indices of the variables on a bound: within 1e-4 of the bound interval's width (of 1e-4,
    scaled units, for a one-sided bound)."""
    if bounds is None:
        return np.zeros(0, int)
    lo, hi = (np.broadcast_to(np.asarray(b, float), z.shape) for b in bounds)
    with np.errstate(invalid="ignore"):
        width = hi - lo
    scale = np.where(np.isfinite(width), width, 1.0)
    return np.flatnonzero(np.minimum(z - lo, hi - z) < 1e-4 * scale)


class ReducedCache:
    """The reduced system (null-space basis and reduced Hessian) of the last iterate at which it was
    formed. Forming it costs more than an Ipopt iteration once an atmosphere profile puts hundreds
    of columns in Z, so the stopping test first evaluates the decrement with the system of an
    earlier iterate within STALE_DISTANCE (scaled units, max norm) and forms a fresh one only when
    that estimate is within STALE_MARGIN of the tolerance: every stop is decided on a fresh system,
    a stale one only ever says "not yet". The gradient is always that of the iterate tested."""

    #: Largest change of any scaled variable for which an earlier system gives the first estimate.
    STALE_DISTANCE = 1e-2
    #: A stale estimate below STALE_MARGIN x DECREMENT_TOL is checked with a fresh system.
    STALE_MARGIN = 100.0

    def __init__(self) -> None:
        self.z: np.ndarray | None = None
        self.system = None

    def at(self, z: np.ndarray) -> bool:
        """Whether the cached system was formed at ``z`` exactly."""
        return self.z is not None and np.array_equal(self.z, z)

    def get(self, nlp: Nlp, z: np.ndarray, max_distance: float = 0.0):
        """The system formed at ``z``, or the cached one if formed within ``max_distance`` of it."""
        if self.z is None or np.max(np.abs(z - self.z)) > max_distance:
            self.z, self.system = z.copy(), reduced_system_at(nlp, z)
        return self.system


def gauss_newton_decrement(nlp: Nlp, z: np.ndarray, fixed: np.ndarray = (),
                           cache: ReducedCache | None = None) -> float:
    """Predicted chi-square decrease of a full constrained Gauss-Newton step from ``z`` (scaled),
    holding the variables ``fixed`` (e.g. those on a bound, as Ipopt's active set does); with a
    ``cache``, a nearby earlier iterate's system may give a large value (see :class:`ReducedCache`),
    a small one is always from a system formed at ``z``. NLPs with latent process values: see
    :func:`kkt_decrement` (no cache)."""
    if nlp.latent:
        return kkt_decrement(nlp, z, fixed)
    cache = cache or ReducedCache()
    grad = nlp.derivatives.gradient(z)
    delta = _decrement(cache.get(nlp, z, ReducedCache.STALE_DISTANCE), grad, fixed)
    if not cache.at(z) and delta <= ReducedCache.STALE_MARGIN * DECREMENT_TOL:
        delta = _decrement(cache.get(nlp, z), grad, fixed)
    return delta


def kkt_decrement(nlp: Nlp, z: np.ndarray, fixed: np.ndarray = ()) -> float:
    """The Gauss-Newton decrement at ``z`` (scaled) from the KKT system instead of a null-space
    basis: -g^T dz with [[H, A^T], [A, 0]] [dz; lambda] = [-g; 0] (H = J^T J, A the constraint
    Jacobian), the ``fixed`` variables' columns left out (their step is zero). Equal to
    g^T Z (Z^T H Z)^-1 Z^T g; the parameters are the factorisation's dense border. Infinite when
    the KKT matrix is singular."""
    h, a = fisher_and_jacobian(nlp, z)
    grad = nlp.derivatives.gradient(z)
    free = np.setdiff1d(np.arange(nlp.n_z), np.asarray(fixed, np.int64))
    place = np.full(nlp.n_z, -1, np.int64)
    place[free] = np.arange(free.size)
    border = place[nlp.parameter_columns]
    try:
        factor = BorderedKkt(kkt_matrix(h[free][:, free], a[:, free]), border[border >= 0])
    except RuntimeError:
        return float("inf")
    dz = factor.solve(np.concatenate([-grad[free], np.zeros(a.shape[0])]))[:free.size]
    return float(-grad[free] @ dz)


def _decrement(system, grad: np.ndarray, fixed) -> float:
    """g^T Z (Z^T H Z)^-1 Z^T g for a reduced system and gradient, ``fixed`` variables held."""
    basis, hr = system.basis, system.hessian
    elim = system.elimination
    if elim is None:
        gr, extra = basis.T @ grad, 0.0
    else:  # [Z_c^T g; g_E] against [[A, B^T], [B, H_EE]]: eliminate g_E through the Schur complement
        g_e = grad[elim.cols]
        core = np.ones(grad.size, bool)
        core[elim.cols] = False
        gr = basis[core].T @ grad[core] - system.coupling.T @ g_e
        extra = float(g_e @ elim.lu.solve(g_e))
    fixed = np.asarray(fixed, int)
    if fixed.size:
        n = null_space(basis[fixed])
        gr, hr = n.T @ gr, n.T @ hr @ n
    try:
        return float(gr @ np.linalg.solve(hr, gr)) + extra
    except np.linalg.LinAlgError:
        return float("inf")


def decrement_if_feasible(nlp: Nlp, z: np.ndarray, g: np.ndarray,
                          bounds: tuple[np.ndarray, np.ndarray] | None,
                          cache: ReducedCache | None = None) -> float | None:
    """The Gauss-Newton decrement at ``z`` with the variables on a bound held, or None when the
    constraint values ``g`` violate FEASIBILITY_TOL (the test is not made)."""
    if g.size and np.abs(g).max() > FEASIBILITY_TOL:
        return None
    return gauss_newton_decrement(nlp, z, at_bounds(z, bounds), cache)


class Interruption:
    """Ctrl-C (or the command line's SIGTERM exception, a ``KeyboardInterrupt``) during one solve.

    CasADi turns an exception into a failed evaluation, so: the first error raised inside any Ipopt
    callback is kept; once an interrupt is kept, every callback raises it again (Ipopt gives up at
    once, the iteration callback asks it to stop), and :meth:`after_solve` raises it after Ipopt has
    returned. When CasADi's own interrupt check caught the signal between callbacks, Ipopt ends with
    ``NonIpopt_Exception_Thrown`` while no callback failed: :meth:`after_solve` raises
    ``KeyboardInterrupt`` then too, so that a loop of solves (a profile) stops at once.
    """

    def __init__(self) -> None:
        self.first: BaseException | None = None

    @property
    def error(self) -> BaseException | None:
        """The kept interrupt (None if none, or if the first error was an ordinary exception)."""
        return None if self.first is None or isinstance(self.first, Exception) else self.first

    def check(self) -> None:
        """Raise the kept interrupt, if any."""
        if self.error is not None:
            raise self.error

    def keep(self, err: BaseException) -> BaseException:
        """Keep the first error of a callback; return what the callback should raise: ``err``, or the
        interrupt in its cause chain (a signal inside a CasADi-to-numpy conversion surfaces as a
        ``SystemError`` caused by the ``KeyboardInterrupt``), or a ``KeyboardInterrupt`` for a
        RuntimeError whose text ends in ``KeyboardInterrupt`` (CasADi's report of one)."""
        seen, inner = set(), err
        while inner is not None and isinstance(inner, Exception) and id(inner) not in seen:
            seen.add(id(inner))
            inner = inner.__cause__ or inner.__context__
        raised = inner if inner is not None and not isinstance(inner, Exception) else err
        if isinstance(raised, RuntimeError) and str(raised).rstrip().endswith("KeyboardInterrupt"):
            # CasADi's own signal check inside a nested Function call (e.g. the block evaluator)
            # reports the interrupt only as the last line of a RuntimeError's text
            raised = KeyboardInterrupt("interrupted inside a CasADi function call")
        if self.first is None:
            self.first = raised
        return raised

    def after_solve(self, status: str) -> None:
        """Raise the interrupt that stopped Ipopt (``status``: its return status), if one did."""
        self.check()
        if status == "NonIpopt_Exception_Thrown" and self.first is None:
            raise KeyboardInterrupt("Ipopt stopped by an exception outside the callbacks (an interrupt)")


class DecrementStop(ca.Callback):
    """Ipopt iteration callback: log the progress, and stop when the iterate is feasible and its
    decrement is small.

    At every iterate it logs (INFO, logger ``casrecon.estimation.engine.convergence``) one line
    ``iteration K: chi-square X, constraint violation Y`` (chi-square = 2 f plus the NLP's constant
    chi-square; violation = max |g|, scaled units); the level and a label before the line are those
    of the :func:`iteration_logging` block it is made in. ``stopped_at`` holds the decrement that
    stopped Ipopt (None if it never did); Ipopt then reports User_Requested_Stop and the last
    iterate is the estimate.
    """

    def __init__(self, nlp: Nlp, bounds: tuple[np.ndarray, np.ndarray] | None = None,
                 interruption: Interruption | None = None) -> None:
        ca.Callback.__init__(self)
        self.interruption = interruption if interruption is not None else Interruption()
        self.nlp, self.n_z, self.n_g, self.bounds = nlp, nlp.n_z, nlp.n_g, bounds
        self.const_chi2 = float(sum(nlp.const_chi2.values()))
        self.iteration = 0
        self.log_level, self.label = _ITERATION_LOG.get()
        self.previous_f: float | None = None
        self.stopped_at: float | None = None
        self.cache = ReducedCache()
        self.construct("decrement_stop", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        n = {"x": self.n_z, "lam_x": self.n_z, "g": self.n_g, "lam_g": self.n_g, "f": 1, "lam_p": 0}
        return ca.Sparsity.dense(n[ca.nlpsol_out(i)], 1)

    def eval(self, args):
        if self.interruption.error is not None:
            return [1]
        try:
            return self.stop(args)
        except BaseException as err:
            raised = self.interruption.keep(err)
            if raised is err:
                raise
            raise raised from None

    def stop(self, args) -> list[int]:
        """``[1]`` to stop Ipopt at this iterate, else ``[0]``."""
        f = float(args[1])
        self.log_progress(f, args[2])
        previous, self.previous_f = self.previous_f, f
        if previous is None or abs(f - previous) > OBJECTIVE_CHANGE * max(abs(f), 1.0):
            return [0]
        delta = decrement_if_feasible(self.nlp, np.asarray(args[0]).ravel(), np.asarray(args[2]).ravel(), self.bounds,
                                      self.cache)
        if delta is not None and delta <= DECREMENT_TOL:
            self.stopped_at = delta
            return [1]
        return [0]

    def log_progress(self, f: float, g) -> None:
        """Log this iterate's chi-square and constraint violation (at :attr:`log_level`), and count it."""
        if LOG.isEnabledFor(self.log_level):
            g = np.asarray(g).ravel()
            violation = float(np.abs(g).max()) if g.size else 0.0
            log_iteration(self.log_level, self.label, self.iteration, 2.0 * f + self.const_chi2, violation)
        self.iteration += 1
