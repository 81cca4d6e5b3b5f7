"""Column names of ``aero_coefficients.csv`` (one place, read by the writer and the figures; no
CasADi here so the figure code can import it cheaply).

Every coefficient is dimensionless. Body-axis force coefficients follow docs/design.md (Sign
conventions): F = qbar S (-C_A, C_Y, -C_N); moment coefficients are about the moment reference point
(MRP), M = qbar S d (C_l, C_m, C_n); both are totals (static, damping and, with spin vanes, the vane
roll moment). ``CN_crossflow`` and ``Cm_crossflow`` are the normal-force and pitching-moment
coefficients in the crossflow plane, C_N e_c,z - C_Y e_c,y and C_m e_c,z - C_n e_c,y (e_c the
crossflow direction): for the axisymmetric database they are its C_N(alpha_T) (> 0) and
C_m(alpha_T) (< 0 restoring), plus damping.
"""

from __future__ import annotations

#: Time and flow columns: IMU clock (s), flight time since release (s), total angle of attack (deg),
#: dynamic pressure (Pa).
TIME_IMU = "time_imu_s"
FLIGHT_TIME = "flight_time_s"
ALPHA_T = "alpha_t_deg"
QBAR = "qbar_pa"

#: The coefficients, in file order (all dimensionless).
COEFFICIENTS = ("CA", "CY", "CN", "Cl", "Cm", "Cn", "CN_crossflow", "Cm_crossflow")
#: The three variants: from the measurements (IMU), the best-fit database and the nominal database
#: along the reconstructed trajectory.
RECONSTRUCTED, BEST_FIT, NOMINAL = "reconstructed", "best_fit", "nominal"
#: Suffix of a 3-sigma column (same unit as its value: dimensionless).
THREE_SIGMA = "3sigma"


def column(coefficient: str, variant: str) -> str:
    """Column of ``coefficient`` (one of COEFFICIENTS) of ``variant`` (RECONSTRUCTED, BEST_FIT, NOMINAL)."""
    return f"{coefficient}_{variant}"


def sigma_column(coefficient: str, variant: str) -> str:
    """Column of the 3-sigma of ``coefficient`` of ``variant`` (RECONSTRUCTED or BEST_FIT)."""
    return f"{coefficient}_{variant}_{THREE_SIGMA}"


def all_columns() -> tuple[str, ...]:
    """Every column of aero_coefficients.csv, in file order."""
    cols = [TIME_IMU, FLIGHT_TIME, ALPHA_T, QBAR]
    for c in COEFFICIENTS:
        cols += [column(c, RECONSTRUCTED), sigma_column(c, RECONSTRUCTED), column(c, BEST_FIT),
                 sigma_column(c, BEST_FIT), column(c, NOMINAL)]
    return tuple(cols)
