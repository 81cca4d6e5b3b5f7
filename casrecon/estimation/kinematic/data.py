"""What an IMU-driven (kinematic) reconstruction needs: the IMU record, the position and velocity
fixes, the barometer, and the options of the fit (docs/design.md: Kinematic reconstruction).

Time base: the IMU clock. Fix and barometer times are already on it (for a 6-DOF problem's data the
receiver clock's guessed offset is applied, and :attr:`KinematicOptions.clock_sigma_s` lets the fit
estimate what remains).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from casrecon.io.baro import HEIGHT_SCALE_SIGMA, BaroConfig
from casrecon.physics.sensor_errors import GpsErrorModel


@dataclass(frozen=True)
class KinematicOptions:
    """Settings of a kinematic fit (SI units).

    Attributes
    ----------
    gyro_noise_radps, accel_noise_mps2 : float
        White noise 1-sigma of one IMU sample, per axis (rad/s, m/s^2); the noise density is
        sigma^2 times the sample period.
    gyro_bias_sigma_radps, accel_bias_sigma_mps2 : float
        Prior 1-sigma of the constant biases (0: held at zero).
    gyro_scale_sigma, accel_scale_sigma : float
        Prior 1-sigma of the scale-factor errors (fraction; 0: held at zero).
    gyro_misalignment_sigma, accel_misalignment_sigma : float
        Prior 1-sigma of each axis's sensitivity to the other axes (rad; 0: held at zero).
    saturated_gyro_sigma_radps, saturated_accel_sigma_mps2 : float
        Noise 1-sigma given to a saturated (clipped) sample, whose value is bridged by interpolation,
        and to a sample of an aliased stretch (``KinematicData.imu_aliased``), whose value is kept.
    gps_lever_m : (3,) tuple
        GPS antenna minus IMU position, IMU axes, m.
    latitude_rad, ground_alt_msl_m : float
        Site (for normal gravity and the Earth rate) and the NED origin's altitude.
    gravity : str
        ``"wgs84"`` (normal gravity at the altitude), ``"constant"`` (at the ground) or ``"off"``.
    earth_rotation : bool
        Coriolis acceleration in the velocity change.
    gyro_senses_earth_rate : bool
        Whether the gyros measure the rate against inertial space (a real gyro; the Earth's rate is
        then removed) or against NED (casrecon's simulator).
    clock_sigma_s : float
        Prior 1-sigma of the IMU-to-receiver clock offset still to estimate (0: none).
    clock_guess_s : float
        The offset already applied to the fix times, s.
    max_node_spacing_s : float
        Longest interval between nodes; nodes sit on the fixes and fill longer gaps.
    gps_errors : GpsErrorModel
        Time-correlated GPS errors (white by default).
    baro_bias_sigma_pa : float
        Prior 1-sigma of the barometer's constant bias, Pa.
    baro_height_scale_sigma : float
        Prior 1-sigma of the scale k of the height above the ground at which the barometer reads the
        profile (fraction: about 0.035 per 10 K between the day's air and the profile's).
    linear_solver, max_iter, tol
        Ipopt settings.
    """

    gyro_noise_radps: float
    accel_noise_mps2: float
    gyro_bias_sigma_radps: float
    accel_bias_sigma_mps2: float
    gyro_scale_sigma: float = 0.0
    accel_scale_sigma: float = 0.0
    gyro_misalignment_sigma: float = 0.0
    accel_misalignment_sigma: float = 0.0
    saturated_gyro_sigma_radps: float = 1.0
    saturated_accel_sigma_mps2: float = 10.0
    gps_lever_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    latitude_rad: float = 0.0
    ground_alt_msl_m: float = 0.0
    gravity: str = "wgs84"
    earth_rotation: bool = False
    gyro_senses_earth_rate: bool = True
    clock_sigma_s: float = 0.0
    clock_guess_s: float = 0.0
    max_node_spacing_s: float = 0.5
    gps_errors: GpsErrorModel = field(default_factory=GpsErrorModel.white)
    baro_bias_sigma_pa: float = BaroConfig.bias_sigma_pa
    baro_height_scale_sigma: float = HEIGHT_SCALE_SIGMA
    linear_solver: str = "mumps"
    max_iter: int = 100
    tol: float = 1e-8

    @property
    def imu_prior_sigmas(self) -> np.ndarray:
        """Prior 1-sigma of the 24 IMU error parameters (order of ``preintegration.IMU_PARAMETERS``)."""
        return np.r_[np.repeat([self.gyro_bias_sigma_radps, self.accel_bias_sigma_mps2, self.gyro_scale_sigma,
                                self.accel_scale_sigma], 3),
                     np.repeat([self.gyro_misalignment_sigma, self.accel_misalignment_sigma], 6)]


@dataclass(frozen=True)
class KinematicData:
    """The measurements of one kinematic fit, on the IMU clock (SI, IMU axes, site NED).

    Attributes
    ----------
    imu_time_s : (N,) array
    gyro_radps, accel_mps2 : (N, 3) arrays
        As measured (IMU axes).
    gyro_valid, accel_valid : (N, 3) bool arrays
        False where a sample is saturated.
    fix_time_s : (M,) array
        Fix times on the IMU clock (with the guessed clock offset applied).
    fix_y : (M, 6) array
        Antenna position (m, NED from the site's ground point) and velocity (m/s); NaN where the
        receiver gave no value.
    fix_sigma : (M, 6) array
        1-sigma of each (inf where missing).
    baro_time_s, baro_pressure_pa : (B,) arrays or None
    baro_noise_pa : float
    atmosphere : casrecon.physics.atmosphere.Atmosphere or None
        For the barometer's pressure-altitude relation (sounding or standard).
    window : (float, float)
        Span reconstructed, s.
    notes : tuple of str
    time_ref_s : float
        Value of the common clock at time 0 of this data (UTC seconds, or the flight computer's).
    imu_file : str
        The IMU file, for located errors ("" when unknown).
    imu_lines : (N,) int array or None
        Line of each IMU sample in ``imu_file`` (None when unknown).
    imu_aliased : (N,) bool array or None
        True where a sample lies in a stretch whose rotation the sampling does not resolve
        (:func:`~casrecon.estimation.kinematic.imu_record.aliased_samples`); None: no such sample.
    """

    imu_time_s: np.ndarray
    gyro_radps: np.ndarray
    accel_mps2: np.ndarray
    gyro_valid: np.ndarray
    accel_valid: np.ndarray
    fix_time_s: np.ndarray
    fix_y: np.ndarray
    fix_sigma: np.ndarray
    window: tuple[float, float]
    baro_time_s: np.ndarray | None = None
    baro_pressure_pa: np.ndarray | None = None
    baro_noise_pa: float = 3.0
    atmosphere: object | None = None
    notes: tuple[str, ...] = ()
    time_ref_s: float = 0.0
    imu_file: str = ""
    imu_lines: np.ndarray | None = None
    imu_aliased: np.ndarray | None = None

    def noise_sigmas(self, options: KinematicOptions) -> tuple[np.ndarray, np.ndarray]:
        """Per-sample 1-sigma (N, 3) of the gyros and accelerometers, saturated and aliased samples
        inflated to the saturated-sample noise (rad/s, m/s^2)."""
        gyro = np.where(self.gyro_valid, options.gyro_noise_radps, options.saturated_gyro_sigma_radps)
        accel = np.where(self.accel_valid, options.accel_noise_mps2, options.saturated_accel_sigma_mps2)
        if self.imu_aliased is not None:
            gyro = np.where(self.imu_aliased[:, None], np.maximum(gyro, options.saturated_gyro_sigma_radps), gyro)
            accel = np.where(self.imu_aliased[:, None], np.maximum(accel, options.saturated_accel_sigma_mps2), accel)
        return gyro, accel

    def bridged(self) -> tuple[np.ndarray, np.ndarray]:
        """Gyro and accelerometer records with saturated samples replaced by linear interpolation
        between the nearest valid ones (per axis)."""
        out = []
        for values, valid in ((self.gyro_radps, self.gyro_valid), (self.accel_mps2, self.accel_valid)):
            v = values.copy()
            for c in range(3):
                ok = valid[:, c]
                if (~ok).any() and ok.sum() >= 2:
                    v[~ok, c] = np.interp(self.imu_time_s[~ok], self.imu_time_s[ok], values[ok, c])
            out.append(v)
        return out[0], out[1]


#: Half-width of the local line fitted to the IMU samples around a fix's node, s (at least 1.5
#: sample spacings): long enough to average the noise out of the slope, short against a capsule's
#: oscillation.
LOCAL_FIT_HALF_WIDTH_S = 0.05


def local_line(at_s: np.ndarray, sample_t_s: np.ndarray, values: np.ndarray,
               half_width_s: float = LOCAL_FIT_HALF_WIDTH_S) -> tuple[np.ndarray, np.ndarray]:
    """(value, slope per second) at each of ``at_s`` of the least-squares line through the samples
    ``values`` (n, m) within ``half_width_s`` (widened to 1.5 sample spacings) of it; the linear
    interpolation and a zero slope where fewer than two samples are that close."""
    spacing = float(np.median(np.diff(sample_t_s))) if sample_t_s.size > 1 else 1.0
    h = max(half_width_s, 1.5 * spacing)
    lo = np.searchsorted(sample_t_s, at_s - h, side="left")
    hi = np.searchsorted(sample_t_s, at_s + h, side="right")

    def window_sums(x: np.ndarray) -> np.ndarray:
        c = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)])
        return c[hi] - c[lo]

    t = sample_t_s - at_s.mean()          # centred: the sums stay well conditioned
    tk = at_s - at_s.mean()
    n = (hi - lo).astype(float)
    s1 = window_sums(t) - n * tk
    s2 = window_sums(t * t) - 2 * tk * window_sums(t) + n * tk * tk
    sy = window_sums(values)
    sty = window_sums(t[:, None] * values) - tk[:, None] * sy
    det = n * s2 - s1 * s1
    ok = (n >= 2) & (det > 1e-12 * np.maximum(n * s2, 1e-300))
    safe = np.where(ok, det, 1.0)[:, None]
    slope = np.where(ok[:, None], (n[:, None] * sty - s1[:, None] * sy) / safe, 0.0)
    value = np.where(ok[:, None], (s2[:, None] * sy - s1[:, None] * sty) / safe,
                     np.column_stack([np.interp(at_s, sample_t_s, values[:, i]) for i in range(values.shape[1])]))
    return value, slope
