"""The FlySight 2 gyro scale (issue 50), measured without the kinematic fit. Not a test; prints its
figures (about 20 s).

The kinematic fit of FlySight 2 jumps asked for gyro scale factors of +5 to +27 %. Three checks here:

C  counts: the firmware (flysight/flysight-2-firmware, FlySight/imu.c, every version to 2026-02)
   logs ``trunc(count * FS * 1000 / 32768)`` mdps (FS = 2000 deg/s by default); every logged rate
   of the file should be such a value, and almost none a multiple of 70 mdps (the LSM6DSO
   datasheet's sensitivity at +-2000 deg/s). Before the firmware's commit f3967d9 (2026-01-13) the
   product overflowed 32 bits above 524 deg/s: the few rates off the grid are checked against that
   wrap.
G  gravity: on the ground, between two still spells (|rate| < 4 deg/s, | |f| - g | < 0.4 m/s^2, at
   least 5 samples, at most 30 s apart, the accelerometer's direction turned by >= 10 deg), the
   gravity direction carried by the integrated rates (times k, less the bias of the first still
   minute) should land on the measured one. k is fitted (common, then per axis); the residual RMS
   is printed at k = 1 (the file as logged) and at the datasheet ratio 1.14688.
T  turns: under canopy, the rate about the local vertical (the accelerometer's down direction
   before the turns, carried by the gyro) against the GNSS course change in 3 s windows, with an
   intercept (what is left of the bias). The aircraft's climbing turn is printed too: the jumper
   moves in the cabin, so its ratio depends on the chosen ends (1.05 to 1.36) and settles nothing.

Run: python benchmarks/fs2_gyro_scale.py  (reads problems/realdata-fs2-chicago/SENSOR.CSV, TRACK.CSV)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from casrecon.io.flysight import read_flysight
from casrecon.io.sensor import FLYSIGHT2_GYRO_SCALE, read_flysight2_sensor

FOLDER = Path(__file__).resolve().parents[1] / "problems" / "realdata-fs2-chicago"
T_EXIT_REF = 1726601100.0          # 19:25:00 UTC, 20 s before the exit
G0 = 9.80665


def counts_check(path: Path) -> None:
    """C: the logged rates against the firmware's count grid (and its 32-bit wrap)."""
    rows = [line.split(",") for line in path.read_text().splitlines() if line.startswith("$IMU,")]
    mdps = np.array([[round(float(x) * 1000) for x in r[2:5]] for r in rows]).ravel()
    n = np.arange(-32768, 32768, dtype=np.int64)
    grid = np.trunc(n * 2_000_000 / 32768).astype(np.int64)
    wrapped = n * 250_000 & 0xFFFFFFFF            # the old firmware: count * (2e6 / 8) in int32
    wrapped = np.trunc(np.where(wrapped >= 2 ** 31, wrapped - 2 ** 32, wrapped) / 4096).astype(np.int64)
    on = np.isin(mdps, grid)
    print(f"C  {mdps.size} logged rates: {on.sum()} on the firmware grid trunc(count * 2e6 / 32768) "
          f"mdps, {np.isin(mdps, n * 70).mean() * 100:.1f} % on the datasheet's 70 mdps grid")
    for v in mdps[~on]:
        src = n[wrapped == v]
        print(f"   off the grid: {v / 1000:+.3f} deg/s = the 32-bit wrap of count {src.tolist()}, "
              f"true {np.trunc(src * 2e6 / 32768) / 1000} deg/s")


def gravity_check(t, w, f) -> None:
    """G: still-to-still gravity direction against the integrated rates."""
    ground = ((t > T_EXIT_REF - 1650) & (t < T_EXIT_REF - 830)) | (t > T_EXIT_REF + 180)
    bias = w[(t > T_EXIT_REF - 1700) & (t < T_EXIT_REF - 1610)].mean(0)
    still = ((np.linalg.norm(w - bias, axis=1) < np.radians(4.0))
             & (np.abs(np.linalg.norm(f, axis=1) - G0) < 0.4) & ground)
    spells, k = [], 0
    while k < t.size:
        j = k
        while still[k] and j + 1 < t.size and still[j + 1] and t[j + 1] - t[j] < 0.12:
            j += 1
        if still[k] and j - k + 1 >= 5:
            spells.append((k, j))
        k = j + 1

    def unit(a, b):
        m = f[a:b + 1].mean(0)
        return m / np.linalg.norm(m)

    pairs = []
    for (a0, b0), (a1, b1) in zip(spells[:-1], spells[1:]):
        v0, v1 = unit(a0, b0), unit(a1, b1)
        if t[a1] - t[b0] <= 30 and np.degrees(np.arccos(np.clip(v0 @ v1, -1, 1))) >= 10:
            pairs.append((b0, a1, v0, v1))

    def residuals(scale):
        out = []
        for k0, k1, v0, v1 in pairs:
            r = Rotation.identity()
            for i in range(k0, k1):
                r = r * Rotation.from_rotvec(0.5 * (w[i] + w[i + 1] - 2 * bias) * scale * (t[i + 1] - t[i]))
            out.extend(np.cross(r.inv().apply(v0), v1))
        return np.array(out)

    def fit(n_par):
        sol = least_squares(lambda k: residuals(np.resize(k, 3)), np.ones(n_par))
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * np.sum(sol.fun ** 2) / (sol.fun.size - n_par)
        return sol.x, np.sqrt(np.diag(cov)), np.degrees(np.sqrt(np.mean(sol.fun ** 2)))

    rms = {k: np.degrees(np.sqrt(np.mean(residuals(np.full(3, k)) ** 2))) for k in (1.0, FLYSIGHT2_GYRO_SCALE)}
    print(f"G  {len(spells)} still spells on the ground, {len(pairs)} pairs; bias {np.degrees(bias).round(3)} deg/s")
    print(f"   residual RMS {rms[1.0]:.2f} deg at k = 1 (as logged), {rms[FLYSIGHT2_GYRO_SCALE]:.2f} deg at "
          f"k = {FLYSIGHT2_GYRO_SCALE:.5f} (datasheet)")
    k, s, r = fit(1)
    print(f"   common k = {k[0]:.3f} +- {s[0]:.3f} (RMS {r:.2f} deg)")
    k, s, r = fit(3)
    print("   per axis k = " + ", ".join(f"{a} {x:.3f} +- {e:.3f}" for a, x, e in zip("xyz", k, s))
          + f" (RMS {r:.2f} deg; tilt only: each pair sees two axes)")


def turn_check(t, w, f, track) -> None:
    """T: rate about the vertical against the GNSS course, under canopy and in the aircraft."""
    tg = track.time_unix_s
    course = np.unwrap(np.arctan2(track.vel_e_mps, track.vel_n_mps))
    bias = w[(t > T_EXIT_REF - 1700) & (t < T_EXIT_REF - 1610)].mean(0)

    def heading(ta, tb):
        i0, i1 = np.searchsorted(t, ta), np.searchsorted(t, tb)
        m = f[i0 - 6:i0 + 7].mean(0)
        down, psi, r = -m / np.linalg.norm(m), [0.0], Rotation.identity()
        for i in range(i0, i1):
            om, dt = 0.5 * (w[i] + w[i + 1]) - bias, t[i + 1] - t[i]
            psi.append(psi[-1] + om @ r.inv().apply(down) * dt)
            r = r * Rotation.from_rotvec(om * dt)
        return t[i0:i1 + 1], np.array(psi)

    ta, tb, win = T_EXIT_REF + 88, T_EXIT_REF + 166, 3.0
    ti, psi = heading(ta, tb)
    e = np.arange(ta, tb - win + 1e-9, win)
    x = np.interp(e + win, tg, course) - np.interp(e, tg, course)
    y = np.interp(e + win, ti, psi) - np.interp(e, ti, psi)
    a = np.column_stack([np.ones_like(x), x])
    coef = np.linalg.lstsq(a, y, rcond=None)[0]
    cov = np.linalg.inv(a.T @ a) * np.sum((y - a @ coef) ** 2) / (x.size - 2)
    b, sb = coef[1], np.sqrt(cov[1, 1])
    print(f"T  canopy {ta - T_EXIT_REF:.0f} to {tb - T_EXIT_REF:.0f} s after 19:25:00: {x.size} windows of "
          f"{win:g} s, course turns {np.degrees(np.abs(x)).sum():.0f} deg in all; logged/true "
          f"{b:.3f} +- {sb:.3f}: k = {1 / b:.3f} +- {sb / b ** 2:.3f}")
    for a0, a1 in ((-150, -30), (-150, -38), (-120, -38), (-110, -36)):
        ti, psi = heading(T_EXIT_REF + a0, T_EXIT_REF + a1)
        c = np.interp(T_EXIT_REF + a1, tg, course) - np.interp(T_EXIT_REF + a0, tg, course)
        print(f"   aircraft {a0} to {a1} s: course {np.degrees(c):+.1f} deg, gyro {np.degrees(psi[-1]):+.1f} "
              f"deg, ratio {c / psi[-1]:.3f} (the jumper moves in the cabin)")


def main() -> None:
    sensor = read_flysight2_sensor(FOLDER / "SENSOR.CSV", gyro_scale=1.0)   # as logged
    track = read_flysight(FOLDER / "TRACK.CSV")
    t, w, f = sensor.imu_time_unix_s, sensor.imu_gyro_radps, sensor.imu_accel_mps2
    counts_check(FOLDER / "SENSOR.CSV")
    gravity_check(t, w, f)
    turn_check(t, w, f, track)


if __name__ == "__main__":
    main()
