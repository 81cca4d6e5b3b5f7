"""Axisymmetric aerodynamics with the EES dispersion factors (docs/design.md: Aerodynamics).

Sign conventions (body axes x out of the nose, z completing the triad):

- the crossflow direction is e_c = (0, v, w) / sqrt(v^2 + w^2), guarded at alpha_T = 0;
- force F = qbar S (-C_A, C_Y,body, -C_N,body) with C_N,body = C_N e_c,z, C_Y,body = -C_N e_c,y,
  so C_N > 0 opposes the crossflow;
- static moment about the moment reference point M = qbar S d (C_l, C_m,body, C_n,body) with
  C_m,body = C_m e_c,z, C_n,body = -C_m e_c,y, so C_m < 0 restores the nose into the wind;
- damping M += qbar S d (d / 2V) (C_lp p, C_mq q, C_mq r);
- transfer to the centre of mass M_cm = M_MRP + (r_MRP - r_cm) x F.

Two coefficient models share these formulas: :class:`AnalyticCoefficients` (sin alpha_T forms)
and :class:`TableCoefficients` ((Mach, alpha_T) grids, smooth B-spline interpolation).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

#: Dispersion factor names, in the order of the dispersion vector (the EES paper's set, extended). Each is normalised:
#: nominal 0, database 3-sigma = 1. ``CLa_mult`` multiplies the spin-vane lift-curve slope;
#: ``Cmq_add`` adds a constant to C_mq and ``Cmq_a2_add`` adds a term in sin^2(alpha_T), the two
#: pieces of an amplitude-dependent (nonlinear) pitch damping that can sustain a limit cycle.
DISPERSION_NAMES = ("CA_mult", "CN_add", "CNY_mult", "CY_add", "Cm_add", "Cmn_mult", "Cn_add",
                    "Cmq_mult", "Cl_add", "CLa_mult", "Cmq_add", "Cmq_a2_add")

#: Crossflow-speed guard, m/s: keeps e_c and alpha_T smooth at alpha_T = 0.
CROSSFLOW_GUARD_MPS = 1e-6


@dataclass(frozen=True)
class DispersionSizes:
    """3-sigma sizes U of each dispersion factor (see :func:`aero_force_moment`). Multipliers are fractions of the
    coefficient, adders are coefficient units. A size of 0 disables the factor."""

    CA_mult: float = 0.0
    CN_add: float = 0.0
    CNY_mult: float = 0.0
    CY_add: float = 0.0
    Cm_add: float = 0.0
    Cmn_mult: float = 0.0
    Cn_add: float = 0.0
    Cmq_mult: float = 0.0
    Cl_add: float = 0.0
    CLa_mult: float = 0.0
    Cmq_add: float = 0.0
    Cmq_a2_add: float = 0.0


@dataclass(frozen=True)
class AnalyticCoefficients:
    """Analytic coefficients of total angle of attack alpha_T (per radian where it applies).

    C_A = CA0 + CA2 sin^2 aT, C_N = CNa sin aT, C_m = Cma sin aT (about the MRP),
    C_mq = Cmq0 + Cmq2 sin^2 aT, C_lp constant, C_l = Cl0.
    """

    CA0: float
    CA2: float = 0.0
    CNa: float = 0.0
    Cma: float = 0.0
    Cmq0: float = 0.0
    Cmq2: float = 0.0
    Clp: float = 0.0
    Cl0: float = 0.0

    def evaluate(self, mach, alpha_t, sin_at):
        """Coefficients (C_A, C_N, C_m, C_mq, C_lp, C_l) at Mach ``mach`` and alpha_T (rad)."""
        s2 = sin_at * sin_at
        return (self.CA0 + self.CA2 * s2, self.CNa * sin_at, self.Cma * sin_at,
                self.Cmq0 + self.Cmq2 * s2, self.Clp, self.Cl0)


@dataclass(frozen=True)
class TableCoefficients:
    """Coefficients tabulated on a (Mach, alpha_T) grid, cubic B-spline interpolated.

    Parameters
    ----------
    mach : tuple of float
        Mach grid, increasing (at least 4 points for a cubic spline; constant-in-Mach data can
        repeat rows).
    alpha_t_deg : tuple of float
        Total angle of attack grid, deg, increasing.
    CA, CN, Cm, Cmq : tuple of tuple of float
        Values, shape (len(mach), len(alpha_t_deg)). C_N and C_m must vanish at alpha_T = 0.
    Clp, Cl0 : float
        Roll damping and static roll coefficient (constants).
    """

    mach: tuple
    alpha_t_deg: tuple
    CA: tuple
    CN: tuple
    Cm: tuple
    Cmq: tuple
    Clp: float = 0.0
    Cl0: float = 0.0
    _interp: object = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        grid = [np.asarray(self.mach, float), np.radians(np.asarray(self.alpha_t_deg, float))]
        values = np.stack([np.asarray(getattr(self, k), float) for k in ("CA", "CN", "Cm", "Cmq")])
        shape = (len(grid[0]), len(grid[1]))
        if values.shape[1:] != shape:
            raise ValueError(f"aero tables must have shape {shape} (Mach x alpha_T)")
        # casadi expects the first grid dimension to vary fastest, outputs interleaved
        flat = values.transpose(2, 1, 0).ravel(order="C")
        object.__setattr__(self, "_interp", ca.interpolant("aero_table", "bspline", grid, flat.tolist()))

    def evaluate(self, mach, alpha_t, sin_at):
        """Coefficients (C_A, C_N, C_m, C_mq, C_lp, C_l) at Mach ``mach`` and alpha_T (rad)."""
        lo, hi = float(self.mach[0]), float(self.mach[-1])
        c = self._interp(ca.vertcat(ca.fmin(ca.fmax(mach, lo), hi), alpha_t))
        return c[0], c[1], c[2], c[3], self.Clp, self.Cl0


@dataclass(frozen=True)
class SpinVanes:
    """Spin-vane roll model (DAVINCI paper Eqs. 2 to 5).

    Each of ``count`` vanes at radius ``radius_m`` with area ``area_m2`` and incidence
    ``incidence_deg`` gives F_k = qbar (alpha_k - atan(p R / V)) C_La S_k, and the roll moment is
    sum_k F_k R. ``lift_slope_per_rad`` is C_La (2 pi / 5 in the paper), scaled by the
    ``CLa_mult`` dispersion.
    """

    count: int
    radius_m: float
    area_m2: float
    incidence_deg: float
    lift_slope_per_rad: float = 2 * np.pi / 5

    def roll_moment(self, qbar, speed, p, cla_scale):
        """Roll moment about the symmetry axis, N m."""
        alpha_eff = np.radians(self.incidence_deg) - ca.atan(p * self.radius_m / speed)
        return (self.count * qbar * alpha_eff * self.lift_slope_per_rad * cla_scale
                * self.area_m2 * self.radius_m)

    def equilibrium_roll_rate(self, speed) -> float:
        """Roll rate (rad/s) at which the vanes' angle of attack vanishes: tan(alpha_k) = p R / V."""
        return speed * np.tan(np.radians(self.incidence_deg)) / self.radius_m


@dataclass(frozen=True)
class AeroDatabase:
    """An aero model: coefficients, dispersion sizes, optional spin vanes, reference quantities.

    Parameters
    ----------
    name : str
        Label for reports.
    coefficients : AnalyticCoefficients or TableCoefficients
    sizes : DispersionSizes
        3-sigma sizes U of the dispersion factors.
    vanes : SpinVanes, optional
        Spin-vane roll model; when present ``CLa_mult`` scales its lift-curve slope.
    """

    name: str
    coefficients: object
    sizes: DispersionSizes
    vanes: SpinVanes | None = None
    description: str = ""
    source_files: tuple[str, ...] = ()


@dataclass(frozen=True)
class FlowAngles:
    """Air-relative flow quantities in body axes; angles in rad, speed m/s."""

    speed: object
    alpha: object
    beta: object
    alpha_t: object
    sin_at: object
    crossflow_dir: object  # e_c, 3-vector (0, e_y, e_z)


def flow_angles(v_air_body) -> FlowAngles:
    """Flow angles of the air-relative velocity (u, v, w) in body axes: alpha = atan2(w, u),
    beta = asin(v / V), alpha_T = atan2(sqrt(v^2 + w^2), u) (crossflow guarded at alpha_T = 0)."""
    u, v, w = v_air_body[0], v_air_body[1], v_air_body[2]
    speed = ca.sqrt(u * u + v * v + w * w)
    cross = ca.sqrt(v * v + w * w + CROSSFLOW_GUARD_MPS**2)
    return FlowAngles(speed=speed, alpha=ca.atan2(w, u), beta=ca.asin(v / speed),
                      alpha_t=ca.atan2(cross, u), sin_at=cross / speed,
                      crossflow_dir=ca.vertcat(0, v / cross, w / cross))


def aero_force_moment(db: AeroDatabase, v_air_body, omega_body, rho, sound_speed, dispersions,
                      ref_area_m2: float, ref_length_m: float, mrp_minus_cm_m):
    """Aerodynamic force (N) and moment about the centre of mass (N m), body axes.

    Parameters
    ----------
    db : AeroDatabase
    v_air_body : 3-vector
        Air-relative velocity of the vehicle in body axes, m/s.
    omega_body : 3-vector
        Body angular rate (p, q, r), rad/s.
    rho, sound_speed : scalar
        Density kg/m^3 and speed of sound m/s.
    dispersions : vector of len(DISPERSION_NAMES)
        Normalised dispersion factors (3-sigma = 1).
    ref_area_m2, ref_length_m : float
        S and d.
    mrp_minus_cm_m : 3-vector
        r_MRP - r_cm in body axes, m.
    """
    fl = flow_angles(v_air_body)
    qbar = 0.5 * rho * fl.speed**2
    ca_, cn, cm, cmq, clp, cl = db.coefficients.evaluate(fl.speed / sound_speed, fl.alpha_t, fl.sin_at)
    d = dict(zip(DISPERSION_NAMES, [dispersions[i] for i in range(len(DISPERSION_NAMES))]))
    u = db.sizes
    ec = fl.crossflow_dir
    ca_ = ca_ * (1 + u.CA_mult * d["CA_mult"])
    cn_b = cn * ec[2] * (1 + u.CNY_mult * d["CNY_mult"]) + u.CN_add * d["CN_add"]
    cy_b = -cn * ec[1] * (1 + u.CNY_mult * d["CNY_mult"]) + u.CY_add * d["CY_add"]
    cm_b = cm * ec[2] * (1 + u.Cmn_mult * d["Cmn_mult"]) + u.Cm_add * d["Cm_add"]
    cn_yaw = -cm * ec[1] * (1 + u.Cmn_mult * d["Cmn_mult"]) + u.Cn_add * d["Cn_add"]
    cmq = cmq * (1 + u.Cmq_mult * d["Cmq_mult"]) + u.Cmq_add * d["Cmq_add"] \
        + u.Cmq_a2_add * d["Cmq_a2_add"] * fl.sin_at ** 2
    cl = cl + u.Cl_add * d["Cl_add"]
    qs = qbar * ref_area_m2
    force = qs * ca.vertcat(-ca_, cy_b, -cn_b)
    rate_scale = ref_length_m / (2 * fl.speed)
    moment = qs * ref_length_m * ca.vertcat(
        cl + clp * rate_scale * omega_body[0],
        cm_b + cmq * rate_scale * omega_body[1],
        cn_yaw + cmq * rate_scale * omega_body[2])
    if db.vanes is not None:
        cla_scale = 1 + u.CLa_mult * d["CLa_mult"]
        moment[0] += db.vanes.roll_moment(qbar, fl.speed, omega_body[0], cla_scale)
    return force, moment + ca.cross(mrp_minus_cm_m, force)
