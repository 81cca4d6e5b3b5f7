"""Vehicle mass properties, reference quantities and sensor mounts (docs/design.md: Frames and angles; Physics).

All positions are in body axes (x out of the nose), metres, measured from one vehicle reference
point of the user's choice (the EES uses the nose, the Zephyr its centroid). A vehicle whose native
axes differ from body axes gives its mass properties and mounts in native axes together with
``native_to_body``; :meth:`Vehicle.from_native` rotates them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _vec3(x) -> tuple[float, float, float]:
    a = np.asarray(x, dtype=float).reshape(3)
    return (float(a[0]), float(a[1]), float(a[2]))


def _mat3(x) -> tuple[tuple[float, ...], ...]:
    a = np.asarray(x, dtype=float).reshape(3, 3)
    return tuple(tuple(float(v) for v in row) for row in a)


def check_rotation(matrix, what: str) -> np.ndarray:
    """Return ``matrix`` as a 3x3 array, raising ValueError unless it is a proper rotation."""
    r = np.asarray(matrix, dtype=float)
    if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
        raise ValueError(f"{what} must be a proper 3x3 rotation matrix (orthonormal, det +1)")
    return r


@dataclass(frozen=True)
class Vehicle:
    """Rigid vehicle, everything in body axes and SI units.

    Parameters
    ----------
    name : str
    mass_kg : float
    inertia_kgm2 : 3x3
        Full inertia tensor about the centre of mass, body axes (products enter with the usual
        negative sign: I = [[Ixx, -Ixy, -Ixz], ...]).
    cm_m, mrp_m : 3-vectors
        Centre of mass and aerodynamic moment reference point, m.
    ref_area_m2, ref_length_m : float
        Reference area S and length d (the maximum diameter).
    imu_position_m : 3-vector
        IMU location, m.
    imu_to_body : 3x3
        Rotation from IMU sensor axes to body axes: v_body = imu_to_body @ v_imu.
    gps_position_m : 3-vector
        GPS antenna location, m.
    """

    name: str
    mass_kg: float
    inertia_kgm2: tuple
    cm_m: tuple
    mrp_m: tuple
    ref_area_m2: float
    ref_length_m: float
    imu_position_m: tuple = (0.0, 0.0, 0.0)
    imu_to_body: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    gps_position_m: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not self.mass_kg > 0:
            raise ValueError("mass_kg must be positive")
        inertia = np.asarray(self.inertia_kgm2, float)
        if inertia.shape != (3, 3) or not np.allclose(inertia, inertia.T):
            raise ValueError("inertia_kgm2 must be a symmetric 3x3 matrix")
        if np.any(np.linalg.eigvalsh(inertia) <= 0):
            raise ValueError("inertia_kgm2 must be positive definite")
        if not (self.ref_area_m2 > 0 and self.ref_length_m > 0):
            raise ValueError("ref_area_m2 and ref_length_m must be positive")
        check_rotation(self.imu_to_body, "imu_to_body")
        for name in ("inertia_kgm2", "imu_to_body"):
            object.__setattr__(self, name, _mat3(getattr(self, name)))
        for name in ("cm_m", "mrp_m", "imu_position_m", "gps_position_m"):
            object.__setattr__(self, name, _vec3(getattr(self, name)))

    @classmethod
    def from_native(cls, native_to_body, *, inertia_kgm2, cm_m, mrp_m, imu_position_m,
                    imu_to_native, gps_position_m, **kw) -> Vehicle:
        """Build from quantities given in the vehicle's native axes.

        ``native_to_body`` rotates native-axis vectors into body axes (v_b = R v_native); the
        inertia becomes R I R^T and the IMU axes ``imu_to_body = R imu_to_native``.
        """
        r = check_rotation(native_to_body, "native_to_body")
        return cls(inertia_kgm2=r @ np.asarray(inertia_kgm2, float) @ r.T,
                   cm_m=r @ np.asarray(cm_m, float), mrp_m=r @ np.asarray(mrp_m, float),
                   imu_position_m=r @ np.asarray(imu_position_m, float),
                   imu_to_body=r @ check_rotation(imu_to_native, "imu_to_native"),
                   gps_position_m=r @ np.asarray(gps_position_m, float), **kw)

    @staticmethod
    def inertia_from_moments(ixx, iyy, izz, ixy=0.0, ixz=0.0, iyz=0.0) -> np.ndarray:
        """Inertia tensor from moments and products of inertia (products with the usual sign
        convention Ixy = integral of x y dm, entering the tensor negated)."""
        return np.array([[ixx, -ixy, -ixz], [-ixy, iyy, -iyz], [-ixz, -iyz, izz]], float)

    def lever(self, point_m) -> np.ndarray:
        """Vector from the centre of mass to ``point_m``, body axes, m."""
        return np.asarray(point_m, float) - np.asarray(self.cm_m, float)
