"""The vehicle and aero-database TOML files a ``problem.toml`` includes, parsed into
:class:`~casrecon.physics.vehicle.Vehicle` and :class:`~casrecon.physics.aero.AeroDatabase`.

Vehicle file (top level: name, mass_kg, ref_length_m, ref_area_m2, cm_m, mrp_m, native_to_body;
tables [inertia_kgm2], [imu], [gps]); aero file (top level: name, description, model, table, Clp,
Cl0; tables [coefficients], [dispersion_sizes], [vanes]). Every key is listed with its unit and
default in ``docs/problem-toml.md``. Every error is an :class:`InputError` naming the file and field.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from casrecon.io.errors import InputError
from casrecon.io.toml_fields import Fields, load_toml
from casrecon.physics.aero import (
    DISPERSION_NAMES,
    AeroDatabase,
    AnalyticCoefficients,
    DispersionSizes,
    SpinVanes,
    TableCoefficients,
)
from casrecon.physics.vehicle import Vehicle

#: Default rotation matrices (native axes = body axes, IMU axes = native axes).
IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def load_vehicle(path: str | Path) -> Vehicle:
    """Parse a vehicle TOML (mass properties in native axes, mounts, ``native_to_body``)."""
    f = load_toml(path)
    inertia = f.table("inertia_kgm2", required=True)
    moments = {k: inertia.number(k, required=k in ("Ixx", "Iyy", "Izz"), default=0.0)
               for k in ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")}
    inertia.reject_unknown()
    imu = f.table("imu") or Fields({}, f.path, "imu.")
    gps = f.table("gps") or Fields({}, f.path, "gps.")
    d = f.number("ref_length_m", required=True, positive=True)
    kw = dict(name=f.string("name", required=True), mass_kg=f.number("mass_kg", required=True, positive=True),
              ref_length_m=d, ref_area_m2=f.number("ref_area_m2", np.pi * d * d / 4, positive=True))
    try:
        vehicle = Vehicle.from_native(
            f.matrix("native_to_body", IDENTITY), inertia_kgm2=Vehicle.inertia_from_moments(**{
                k.lower(): v for k, v in moments.items()}),
            cm_m=f.vector("cm_m", 3, required=True), mrp_m=f.vector("mrp_m", 3, required=True),
            imu_position_m=imu.vector("position_m", 3, (0.0, 0.0, 0.0)),
            imu_to_native=imu.matrix("to_native", IDENTITY),
            gps_position_m=gps.vector("position_m", 3, (0.0, 0.0, 0.0)), **kw)
    except ValueError as err:
        raise InputError(path, str(err)) from None
    for t in (imu, gps, f):
        t.reject_unknown()
    return vehicle


def load_aero(path: str | Path) -> AeroDatabase:
    """Parse an aero database TOML: ``model = "analytic"`` with ``[coefficients]``, or
    ``model = "table"`` with ``table = "file.csv"`` (columns mach, alpha_t_deg, CA, CN, Cm, Cmq);
    ``[dispersion_sizes]`` (3-sigma sizes U) and optional ``[vanes]``."""
    f = load_toml(path)
    model = f.string("model", required=True, choices=("analytic", "table"))
    sources = (str(Path(path).resolve()),)
    if model == "analytic":
        coeffs = _analytic(f.table("coefficients", required=True))
    else:
        table_path = f.path_of("table", required=True)
        coeffs = _table(table_path, f.number("Clp", 0.0), f.number("Cl0", 0.0))
        sources += (str(table_path),)
    sizes_t = f.table("dispersion_sizes", required=True)
    sizes = DispersionSizes(**{n: sizes_t.number(n, 0.0, minimum=0.0) for n in DISPERSION_NAMES})
    sizes_t.reject_unknown()
    vanes_t = f.table("vanes")
    vanes = None
    if vanes_t is not None:
        vanes = SpinVanes(count=vanes_t.integer("count", 0, 1),
                          radius_m=vanes_t.number("radius_m", required=True, positive=True),
                          area_m2=vanes_t.number("area_m2", required=True, positive=True),
                          incidence_deg=vanes_t.number("incidence_deg", required=True),
                          lift_slope_per_rad=vanes_t.number("lift_slope_per_rad", 2 * np.pi / 5, positive=True))
        vanes_t.reject_unknown()
    db = AeroDatabase(name=f.string("name", required=True), coefficients=coeffs, sizes=sizes, vanes=vanes,
                      description=f.string("description", ""), source_files=sources)
    f.reject_unknown()
    return db


def _analytic(t: Fields) -> AnalyticCoefficients:
    names = ("CA0", "CA2", "CNa", "Cma", "Cmq0", "Cmq2", "Clp", "Cl0")
    c = AnalyticCoefficients(**{n: t.number(n, required=(n == "CA0"), default=0.0) for n in names})
    t.reject_unknown()
    return c


TABLE_COLUMNS = ("mach", "alpha_t_deg", "CA", "CN", "Cm", "Cmq")


def _table(path: Path, clp: float, cl0: float) -> TableCoefficients:
    """Read a (Mach, alpha_T) table CSV laid out as a full grid, one row per point."""
    try:
        with open(path, encoding="utf-8") as fh:
            header = [h.strip() for h in fh.readline().strip().split(",")]
        if tuple(header) != TABLE_COLUMNS:
            order = " (the same columns in another order)" if sorted(header) == sorted(TABLE_COLUMNS) else ""
            raise InputError(path, f"not an aero table CSV: expected the header line {','.join(TABLE_COLUMNS)}"
                             f"{order}", line=1)
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except InputError:
        raise
    except (OSError, ValueError, UnicodeDecodeError) as err:
        raise InputError(path, f"cannot read aero table: {err}") from None
    if not np.all(np.isfinite(data)):
        raise InputError(path, "aero table holds a non-finite value")
    mach, alpha = np.unique(data[:, 0]), np.unique(data[:, 1])
    if data.shape[0] != mach.size * alpha.size or min(mach.size, alpha.size) < 4:
        raise InputError(path, "aero table must be a full grid of at least 4 Mach x 4 alpha_T points")
    order = np.lexsort((data[:, 1], data[:, 0]))
    grid = data[order].reshape(mach.size, alpha.size, len(TABLE_COLUMNS))
    cols = {name: tuple(map(tuple, grid[:, :, i])) for i, name in enumerate(TABLE_COLUMNS) if i >= 2}
    return TableCoefficients(mach=tuple(mach), alpha_t_deg=tuple(alpha), Clp=clp, Cl0=cl0, **cols)
