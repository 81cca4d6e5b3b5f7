"""Sample kinds (:mod:`casrecon.estimation.kinds.samples`) in the kinematic fit: one residual term per
kind, its parameters appended after the fit's own.

Time: a kind's samples (``time_unix_s``) must be stamped on the clock of the fixes, and the
kinematic data's time 0 is ``data.time_ref_s`` on that clock: a kinematic problem's common clock
(:func:`~.inputs.inputs_from_config`: UTC, or the flight computer's own seconds when its files share
that clock); for a 6-DOF problem's data (:func:`~.inputs.data_from_problem`, whose ``time_ref_s`` is
0) replace ``time_ref_s`` by the IMU clock's UTC at zero before the fit. Like the fixes, a sample
is placed with the guessed clock offset (``options.clock_guess_s``) on the interval that holds it,
and moved within it by the estimated offset when the fit estimates one (``t + guess - clock`` on
the IMU clock; the fit places the samples again with the fixes when the estimate moves far from
the guess).

State at a sample's fraction tau of the interval between nodes k and k+1 (length T): per axis the
cubic Hermite of position through (p, v) at the two nodes, its derivative for the velocity, the
quaternion linearly interpolated between the sign-aligned node quaternions and normalised, the
atmosphere's pressure and density at the position's altitude (the data's atmosphere, or the
standard one without it), and no air velocity (the kinematic fit has no wind: a kind that needs it
refuses the fit). The reference point and axes are the IMU's.
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.engine.checks import FitError
from casrecon.estimation.kinds.samples import BodyState, SampleKind
from casrecon.estimation.kinematic.data import KinematicData, KinematicOptions
from casrecon.estimation.kinematic.terms import N_STATE, unscale_state
from casrecon.estimation.sixdof.parameters import ParameterSet, ParameterSpec
from casrecon.estimation.sixdof.transcription import hermite
from casrecon.physics.atmosphere import Atmosphere

#: Name of the kinematic fit's clock-offset parameter (s).
CLOCK = "clock_offset_s"


def sample_parameters(kinds: Sequence[SampleKind]) -> tuple[ParameterSpec, ...]:
    """The parameters of ``kinds``, in order: appended after the kinematic fit's own."""
    return tuple(spec for kind in kinds for spec in kind.parameters())


def interval_state(tau, dur, xk, xk1, ground_alt_msl_m: float, atmosphere) -> BodyState:
    """The IMU's :class:`BodyState` at fraction ``tau`` of an interval of length ``dur`` (s) from the
    SI node states ``xk``, ``xk1`` (p, v, q), see the module docstring (CasADi)."""
    t2 = tau * tau
    position = hermite(tau, dur, xk[0:3], xk[3:6], xk1[0:3], xk1[3:6])
    velocity = ((6 * t2 - 6 * tau) * (xk[0:3] - xk1[0:3]) / dur + (3 * t2 - 4 * tau + 1) * xk[3:6]
                + (3 * t2 - 2 * tau) * xk1[3:6])
    qk, qk1 = xk[6:10], xk1[6:10]
    q = (1 - tau) * qk + tau * ca.sign(ca.dot(qk, qk1)) * qk1
    q = q / ca.norm_2(q)
    alt = ground_alt_msl_m - position[2]
    air = atmosphere.at(alt)
    return BodyState(position, velocity, q, alt, air.pressure, air.density, None)


def sample_terms(kinds: Sequence[SampleKind], data: KinematicData, options: KinematicOptions, nodes: np.ndarray,
                 params: ParameterSet, theta_cols: np.ndarray, state_cols: np.ndarray) -> list[Term]:
    """One residual term per kind (group: the kind's name) of the samples inside the nodes' span.

    Parameters
    ----------
    kinds : sequence of SampleKind
        Lever arms from the IMU, IMU axes.
    data, options
        The fit's data (``time_ref_s``: the receiver clock at time 0) and options (``clock_guess_s``).
    nodes : (K,) array
        Node times, s.
    params : ParameterSet
        The fit's parameters, the kinds' among them; ``theta_cols`` their z columns.
    state_cols : (K, 10) int array
        z columns of each node's scaled state.

    Raises
    ------
    FitError
        A kind without a sample inside the span.
    """
    atmosphere = data.atmosphere if data.atmosphere is not None else Atmosphere.standard()
    with_clock = CLOCK in params.names
    terms = []
    for kind in kinds:
        samples = kind.samples
        t = samples.time_unix_s - data.time_ref_s - options.clock_guess_s
        inside = (t >= nodes[0]) & (t <= nodes[-1])
        if not inside.any():
            raise FitError(f"sample kind {kind.name!r}: no sample inside the reconstructed span "
                           f"{data.time_ref_s + nodes[0]:.3f} to {data.time_ref_s + nodes[-1]:.3f} s (receiver clock)")
        t, y, sigma = t[inside], samples.values[inside], samples.sigma[inside]
        k = np.clip(np.searchsorted(nodes, t, side="right") - 1, 0, nodes.size - 2)
        dur = nodes[k + 1] - nodes[k]
        own = kind.parameters()
        xk_s, xk1_s = ca.SX.sym("xk", N_STATE), ca.SX.sym("xk1", N_STATE)
        clock_s, own_s = ca.SX.sym("clock", 1 if with_clock else 0), ca.SX.sym("theta", len(own))
        tau0, dur_s = ca.SX.sym("tau0"), ca.SX.sym("T")
        y_s, inv_s = ca.SX.sym("y", samples.width), ca.SX.sym("inv", samples.width)
        tau = tau0
        if with_clock:
            tau = tau0 + (options.clock_guess_s - clock_s[0] * params.specs[params.index(CLOCK)].scale) / dur_s
        state = interval_state(tau, dur_s, unscale_state(xk_s), unscale_state(xk1_s), options.ground_alt_msl_m,
                               atmosphere)
        theta = {spec.name: own_s[i] * spec.scale for i, spec in enumerate(own)}
        r = (y_s - ca.vec(kind.predict(state, theta))) * inv_s
        block = BlockKind(f"kinematic_{kind.name}", ca.vertcat(xk_s, xk1_s, clock_s, own_s),
                          [tau0, dur_s, y_s, inv_s], r, None)
        cols = [state_cols[k], state_cols[k + 1]]
        if with_clock:
            cols.append(np.full((t.size, 1), theta_cols[params.index(CLOCK)]))
        cols.append(np.tile([theta_cols[params.index(spec.name)] for spec in own], (t.size, 1)).reshape(t.size, -1))
        block_data = [ca.DM((t - nodes[k]) / dur).T, ca.DM(dur).T, ca.DM(y.T), ca.DM(1.0 / sigma.T)]
        terms.append(Term(kind.name, (BlockSet(block, np.column_stack(cols).astype(np.int64), block_data),)))
    return terms
