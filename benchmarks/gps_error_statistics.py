"""Time correlation and scale of real FlySight GPS errors: the measured defaults for a white plus
first-order Gauss-Markov error model (issue 18). Not a test; prints its figures (about 1 minute).

Model, per component c and fix k: error_k = sigma_k * sqrt(r) * (sqrt(1 - f) w_k + sqrt(f) e_k), sigma_k
the receiver's reported accuracy (hAcc north/east, vAcc down, sAcc each velocity component), w white,
e a unit first-order Gauss-Markov process of correlation time tau. Per group (horizontal / vertical
position, horizontal / vertical velocity) we want f, tau and r (empirical error variance / sigma^2:
r < 1 means the receiver is pessimistic).

The truth is unknown, so the errors are isolated where something else fixes it
(casrecon/analysis/gps_error_statistics.py does the fitting, exactly for the detrending used):

V1  velocity at rest: on the ground, with the device still (5 s rolling maximum speed < 0.5 m/s), the
    velocity *is* the error. Autocovariance fit, lags up to 5 s, no detrending.
V2  velocity in flight: second differences of the velocity remove a locally linear truth; the
    scale r is fitted with the V1 shape (f, tau) held; what the dynamics leak in makes it an upper bound.
P1  position, all phases (ground, aircraft, canopy, freefall): position minus the trapezoid integral of
    the GPS velocity, X = p - int v, cancels the trajectory exactly (to dt^3 jerk / 12); what is left is
    the position error minus the integral of the (much smaller) velocity error plus a constant per
    segment. Its structure function D(L) = E[(X(t+L) - X(t))^2] / sigma^2 needs no detrending; a GM
    gives D = 2 r (1 - f) + 2 r f (1 - exp(-L / tau)).
R   the GPS-only point-mass fits of the three problems (freefall): residuals normalised by the reported
    sigma, their lag-1 autocorrelation and white+GM fit; then the same fits run on their own fitted
    trajectory plus errors drawn from the recommended model (2 seeds), to calibrate what the
    fit's residuals show of known errors (the fit absorbs the slow part: tau and r come out short).
I   FlySight 2 IMU (Chicago): the specific-force magnitude from the GPS velocity and from the fit's
    model against the IMU's, to tell GPS error from model error in the fit residuals.

Run: python benchmarks/gps_error_statistics.py [--seeds 2] [--skip-fits]
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np
import pymap3d

from casrecon.analysis.gps_error_statistics import (
    GaussMarkovFit,
    fit_gauss_markov,
    fit_gauss_markov_variogram,
    gauss_markov_series,
    variogram,
)
from casrecon.estimation.pointmass.fit import fit_point_mass
from casrecon.io.flysight import read_flysight, write_flysight1
from casrecon.io.gps_rules import ned_to_geodetic
from casrecon.io.pointmass_problem import SegmentConfig, load_point_mass

ROOT = Path(__file__).resolve().parents[1]
PROBLEMS = {"fs1-byron": "realdata-fs1-byron", "fs2-chicago": "realdata-fs2-chicago",
            "skyderby-411": "realdata-skyderby-411"}
SENSOR = ROOT.parent / "shared/realdata/flysight-speed-ssscoring/fs2-chicago-2024-09-17/SENSOR.CSV"
PHASES = ("ground", "aircraft", "canopy", "freefall")
LAGS_S = (0.2, 1.0, 2.0, 5.0, 10.0, 20.0, 40.0, 80.0, 160.0)
G0 = 9.80665


@dataclasses.dataclass
class Track:
    name: str
    t: np.ndarray          # UTC s
    dt: float
    pos: np.ndarray        # (n, 3) NED about the track's last fix, m
    vel: np.ndarray        # (n, 3) m/s
    sigma: np.ndarray      # (n, 6) hAcc, hAcc, vAcc, sAcc x 3
    phase: dict            # phase -> bool mask
    still: np.ndarray      # on the ground and not moving


def load(name: str) -> Track:
    tr = read_flysight(load_point_mass(ROOT / "problems" / PROBLEMS[name]).gps_file)
    t = tr.time_unix_s
    dt = float(np.median(np.diff(t)))
    n, e, d = pymap3d.geodetic2ned(tr.lat_deg, tr.lon_deg, tr.h_msl_m, tr.lat_deg[-1], tr.lon_deg[-1], 0.0)
    vel = np.column_stack([tr.vel_n_mps, tr.vel_e_mps, tr.vel_d_mps])
    sigma = np.column_stack([tr.h_acc_m, tr.h_acc_m, tr.v_acc_m, tr.s_acc_mps, tr.s_acc_mps, tr.s_acc_mps])
    good = (tr.h_acc_m < 5) & (tr.v_acc_m < 8) & (tr.s_acc_mps < 1.5) & ((tr.num_sv < 0) | (tr.num_sv >= 6))
    good &= np.r_[True, np.abs(np.diff(t) - dt) < 1e-3]  # a gap starts a new run
    speed, vd = np.linalg.norm(vel, axis=1), vel[:, 2]
    w = int(round(2.5 / dt))
    rolling = np.array([speed[max(i - w, 0):i + w + 1].max() for i in range(speed.size)])
    phase = {"ground": good & (speed < 3), "aircraft": good & (speed > 25) & (np.abs(vd) < 15),
             "canopy": good & (speed > 3) & (speed < 30) & (vd > 2) & (vd < 25), "freefall": good & (vd > 25)}
    return Track(name, t, dt, np.column_stack([n, e, d]), vel, sigma, phase, good & (rolling < 0.5))


def runs(mask: np.ndarray, min_len: int) -> list[tuple[int, int]]:
    """Contiguous runs [a, b) of True at least min_len long (a gap in time already breaks the mask)."""
    edges = np.diff(np.r_[0, mask.astype(int), 0])
    return [(a, b) for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)) if b - a >= min_len]


def chunks(a: int, b: int, n: int) -> list[tuple[int, int]]:
    return [(s, s + n) for s in range(a, b - n + 1, n)] or [(a, b)]


def fmt(fit: GaussMarkovFit, shape_free: bool = True) -> str:
    s = f"r {fit.variance_ratio:7.3f}"
    s += f" +- {fit.variance_ratio_se:.3f}" if np.isfinite(fit.variance_ratio_se) else "         "
    if shape_free:
        s += f"  f {fit.correlated_fraction:5.3f}"
        s += f" +- {fit.correlated_fraction_se:.3f}" if np.isfinite(fit.correlated_fraction_se) else "         "
        tau = f">{fit.tau_s:.0f}" if fit.tau_at_bound else f"{fit.tau_s:.2f}"
        s += f"  tau {tau:>7} s" + (f" (x/ {fit.tau_factor:.2f})" if np.isfinite(fit.tau_factor) else "")
    return s + f"  [{fit.n_samples} samples, {fit.n_segments} segments]"


GROUPS = {"vel H": (3, 4), "vel D": (5,), "pos H": (0, 1), "pos D": (2,)}


# ---------------------------------------------------------------- V1, V2: velocity
def velocity_at_rest(tracks: list[Track]) -> dict[str, GaussMarkovFit]:
    print("\nV1  velocity at rest (truth = 0): autocovariance fit, lags <= 5 s, 30-s pieces")
    pooled = {}
    for group in ("vel H", "vel D"):
        by_dt: dict[float, list[np.ndarray]] = {}
        for tk in tracks:
            segs = [tk.vel[a:b, c - 3] / tk.sigma[a:b, c] for a0, b0 in runs(tk.still, int(20 / tk.dt))
                    for a, b in chunks(a0, b0, int(30 / tk.dt)) for c in GROUPS[group]]
            if segs:
                fit = fit_gauss_markov(segs, tk.dt, int(5 / tk.dt))
                print(f"  {tk.name:13s} {group}: {fmt(fit)}")
                by_dt.setdefault(tk.dt, []).extend(segs)
        # pooled: at the finer rate (FlySight 2, 10 Hz) plus FlySight 1 at 5 Hz fitted alone, weighted
        fits = [fit_gauss_markov(s, dt, int(5 / dt)) for dt, s in by_dt.items()]
        w = np.array([f.n_samples * dt for f, dt in zip(fits, by_dt)])
        pooled[group] = GaussMarkovFit(
            variance_ratio=float(np.average([f.variance_ratio for f in fits], weights=w)),
            correlated_fraction=float(np.average([f.correlated_fraction for f in fits], weights=w)),
            tau_s=float(np.exp(np.average([np.log(f.tau_s) for f in fits], weights=w))), tau_at_bound=False,
            n_samples=int(sum(f.n_samples for f in fits)), n_segments=int(sum(f.n_segments for f in fits)),
            max_lag=0, detrend_order=-1)
        print(f"  {'pooled':13s} {group}: {fmt(pooled[group])}   (weighted by duration)")
    return pooled


def velocity_in_flight(tracks: list[Track], shape: dict[str, GaussMarkovFit]) -> dict[str, float]:
    print("\nV2  velocity in flight: second differences of 10-s pieces (each divided by its RMS sAcc, so the "
          "truth's linear part cancels), r fitted with the V1 shape held; dynamics leak in, so an upper bound "
          "('still': the same on the V1 data, a check of the method)")
    bound = {}
    for group in ("vel H", "vel D"):
        f, tau = shape[group].correlated_fraction, shape[group].tau_s
        for ph in ("still", "aircraft", "canopy", "freefall"):
            line, values = [], []
            for tk in tracks:
                mask = tk.still if ph == "still" else tk.phase[ph]
                segs = [tk.vel[a:b, c - 3] / np.sqrt(np.mean(tk.sigma[a:b, c] ** 2))
                        for a0, b0 in runs(mask, int(5 / tk.dt)) for a, b in chunks(a0, b0, int(10 / tk.dt))
                        for c in GROUPS[group]]
                if segs:
                    fit = fit_gauss_markov(segs, tk.dt, 4, differences=2, shape=(f, tau))
                    line.append(f"{tk.name} {fit.variance_ratio:6.3f}")
                    values.append(fit.variance_ratio)
            print(f"  {group} {ph:9s} r: " + ";  ".join(line))
        bound[group] = max(values)
    return bound


# ---------------------------------------------------------------- P1: position
def consistency_segments(tk: Track, mask: np.ndarray, comps: tuple[int, ...], direct: bool = False):
    """X = p - cumulative trapezoid of v on each run of ``mask``, with its sigma, at 5 Hz (``direct``:
    p itself, for a device at rest)."""
    step = max(int(round(0.2 / tk.dt)), 1)
    out = []
    for a, b in runs(mask, int(10 / tk.dt)):
        steps = (tk.vel[a + 1:b] + tk.vel[a:b - 1]) / 2 * np.diff(tk.t[a:b])[:, None]
        x = tk.pos[a:b] - (0.0 if direct else np.vstack([np.zeros(3), np.cumsum(steps, axis=0)]))
        out += [(x[::step, c], tk.sigma[a:b:step, c]) for c in comps]
    return out


def position(tracks: list[Track]) -> dict[str, dict]:
    print("\nP1  position from position-velocity consistency X = p - int v (all phases unless said; 'still p': "
          "the position itself where the device lay still, a check without the velocity)")
    lags = np.array([int(round(s / 0.2)) for s in LAGS_S])
    print("    normalised rms change of the position error sqrt(D(L)/2) at lag L "
          f"(first-order GM with r = 1, tau = 60 s: {' '.join(f'{np.sqrt(1 - np.exp(-s / 60)):.2f}' for s in LAGS_S)})")
    print(f"    {'':24s}" + "".join(f"{s:>7g}s" for s in LAGS_S))
    out = {}
    for group in ("pos H", "pos D"):
        rows = [(tk.name, "all", [tk], [p for p in PHASES]) for tk in tracks]
        rows += [("pooled", ph, tracks, [ph]) for ph in PHASES] + [("pooled", "all", tracks, list(PHASES))]
        rows += [("pooled", "still X", tracks, ["still"]), ("pooled", "still p", tracks, ["still p"])]
        for who, ph, tks, phs in rows:
            segs = [s for tk in tks for p in phs
                    for s in consistency_segments(tk, tk.still if p.startswith("still") else tk.phase[p],
                                                  GROUPS[group], direct=p == "still p")]
            d, _ = variogram([x for x, _ in segs], [s for _, s in segs], lags)
            print(f"  {group} {who:12s} {ph:8s}" + "".join(f"{np.sqrt(v / 2):8.2f}" if np.isfinite(v) else "       -"
                                                           for v in d))
            if who == "pooled" and ph == "all":
                out[group] = {"segments": segs, "d": d}
    for group in ("pos H", "pos D"):
        segs, d = out[group]["segments"], out[group]["d"]
        white = d[0] / 2  # D(0.2 s) / 2 bounds the white variance r (1 - f)
        print(f"  {group}: white part r (1 - f) <= D(0.2 s)/2 = {white:.5f}: f >= {1 - white / 1.0:.4f} "
              "for r >= 1")
        for lo, hi in ((1, 40), (10, 160)):
            sel = [int(round(s / 0.2)) for s in np.geomspace(lo, hi, 12)]
            fit = fit_gauss_markov_variogram([x for x, _ in segs], [s for _, s in segs], 0.2, sel, tau_max_s=3000)
            print(f"  {group} GM fit to D over lags {lo}-{hi} s: {fmt(fit)}; diffusion r f / tau = "
                  f"{fit.variance_ratio * fit.correlated_fraction / fit.tau_s:.4f} /s")
        slope = [d[i] / 2 / LAGS_S[i] for i in range(len(LAGS_S)) if LAGS_S[i] >= 10 and np.isfinite(d[i])]
        out[group]["diffusion"] = float(np.median(slope))
        print(f"  {group}: D(L)/2 / L over 10-160 s: {' '.join(f'{s:.4f}' for s in slope)} /s "
              f"(median {out[group]['diffusion']:.4f}): a random walk on these scales")
    return out


def latency(tracks: list[Track]) -> None:
    print("\nL   freefall: X = p - int v regressed on v per axis (X = a + delta v): delta > 0 is the position "
          "leading the velocity by delta")
    for tk in tracks:
        a, b = max(runs(tk.phase["freefall"], int(10 / tk.dt)), key=lambda r: r[1] - r[0])
        parts = []
        for c, name in enumerate("NED"):
            (x, _), = consistency_segments(tk, np.r_[np.zeros(a, bool), np.ones(b - a, bool),
                                                     np.zeros(tk.t.size - b, bool)], (c,))
            v = tk.vel[a:b:max(int(round(0.2 / tk.dt)), 1), c]
            design = np.column_stack([np.ones(v.size), v])
            coef = np.linalg.lstsq(design, x, rcond=None)[0]
            parts.append(f"{name} {coef[1] * 1000:6.1f} ms (rms {np.std(x):.2f} -> {np.std(x - design @ coef):.2f} m)")
        print(f"  {tk.name:13s} " + ";  ".join(parts))


# ---------------------------------------------------------------- R: the point-mass fits
def residual_stats(nr: np.ndarray, dt: float) -> dict[str, tuple[float, float, GaussMarkovFit]]:
    out = {}
    for group, comps in GROUPS.items():
        segs = [nr[np.isfinite(nr[:, c]), c] for c in comps]
        rms = float(np.sqrt(np.mean(np.concatenate(segs) ** 2)))
        lag1 = float(np.mean([np.corrcoef(s[:-1], s[1:])[0, 1] for s in segs]))
        out[group] = (rms, lag1, fit_gauss_markov(segs, dt, min(int(5 / dt), 30), detrend_order=0))
    return out


def synthetic_track(cfg, fit, model: dict[str, tuple[float, float, float]], rng: np.random.Generator) -> object:
    """The track with the segment's fixes replaced by the fitted trajectory plus drawn errors."""
    tr = read_flysight(cfg.gps_file)
    idx = np.searchsorted(tr.time_unix_s, fit.t_unix - 1e-3)
    dt = float(np.median(np.diff(fit.t_unix)))
    sig = np.column_stack([tr.h_acc_m, tr.h_acc_m, tr.v_acc_m, tr.s_acc_mps, tr.s_acc_mps, tr.s_acc_mps])[idx]
    err = np.zeros_like(fit.states)
    for group, comps in GROUPS.items():
        r, f, tau = model[group]
        for c in comps:
            err[:, c] = sig[:, c] * gauss_markov_series(idx.size, f, tau / dt, rng, r)
    y = fit.states + err
    lat, lon, h = ned_to_geodetic(y[:, :3], cfg.site)
    new = {k: getattr(tr, k).copy() for k in ("lat_deg", "lon_deg", "h_msl_m", "vel_n_mps", "vel_e_mps", "vel_d_mps")}
    for k, v in zip(new, (lat, lon, h, y[:, 3], y[:, 4], y[:, 5])):
        new[k][idx] = v
    return dataclasses.replace(tr, **new)


def fits(seeds: int, model: dict[str, tuple[float, float, float]]) -> dict:
    print("\nR   point-mass fits (freefall): residual / sigma: rms, lag-1 autocorrelation, white+GM fit (mean removed)")
    real = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, prob in PROBLEMS.items():
            cfg = load_point_mass(ROOT / "problems" / prob)
            fit = fit_point_mass(cfg)
            real[name] = fit
            dt = float(np.median(np.diff(fit.t_unix)))
            stats = residual_stats(fit.normalized_residuals, dt)
            seg = SegmentConfig(float(fit.t_unix[0]), float(fit.t_unix[-1]))
            syn = []
            for seed in range(seeds):
                path = Path(tmp) / f"{name}-{seed}.csv"
                write_flysight1(path, synthetic_track(cfg, fit, model, np.random.default_rng(seed)))
                try:
                    sfit = fit_point_mass(dataclasses.replace(cfg, gps_file=path, segment=seg))
                    syn.append(residual_stats(sfit.normalized_residuals, dt))
                except Exception as err:  # noqa: BLE001 - a failed synthetic fit is reported, not fatal
                    print(f"  {name} synthetic seed {seed}: fit failed: {type(err).__name__}: {str(err)[:100]}")
            print(f"  {name} (reduced chi-square {fit.reduced_chi2:.2f}):")
            for group in GROUPS:
                rms, lag1, gm = stats[group]
                line = f"    {group} real      rms {rms:6.2f}  lag1 {lag1:5.2f}  {fmt(gm)}"
                print(line)
                for s in syn:
                    rms, lag1, gm = s[group]
                    print(f"    {group} synthetic rms {rms:6.2f}  lag1 {lag1:5.2f}  {fmt(gm)}")
    return real


def imu_check(chicago_fit) -> None:
    print("\nI   FlySight 2 IMU, Chicago freefall: |specific force| from GPS velocity and from the fit's model "
          "against the IMU's (0.6-s moving averages)")
    if not SENSOR.exists():
        print(f"  skipped: {SENSOR} not found")
        return
    from casrecon.io.sensor import read_flysight2_sensor
    s = read_flysight2_sensor(SENSOR)
    t = chicago_fit.t_unix

    def mag(v: np.ndarray) -> np.ndarray:
        a = np.gradient(v, t, axis=0)
        a[:, 2] -= G0
        return np.linalg.norm(a, axis=1)

    def smooth(x: np.ndarray, tt: np.ndarray) -> np.ndarray:
        return np.array([x[np.abs(tt - c) <= 0.3].mean() for c in tt])

    m = (s.imu_time_unix_s > t[0] - 1) & (s.imu_time_unix_s < t[-1] + 1)
    imu = np.interp(t, s.imu_time_unix_s[m], smooth(np.linalg.norm(s.imu_accel_mps2[m], axis=1), s.imu_time_unix_s[m]))
    gps, model = smooth(mag(chicago_fit.y[:, 3:]), t), smooth(mag(chicago_fit.states[:, 3:]), t)
    print(f"  rms difference to the IMU: GPS velocity {np.sqrt(np.mean((gps - imu) ** 2)):.2f} m/s^2, "
          f"fit model {np.sqrt(np.mean((model - imu) ** 2)):.2f} m/s^2 (IMU's own spread {imu.std():.1f} m/s^2)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2, help="synthetic refits per track (default 2)")
    ap.add_argument("--skip-fits", action="store_true", help="skip the point-mass fits (R, I)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    tracks = [load(n) for n in PROBLEMS]
    for tk in tracks:
        dur = {p: f"{tk.phase[p].sum() * tk.dt:.0f}" for p in PHASES}
        print(f"{tk.name}: {tk.t.size} fixes every {tk.dt:.1f} s; seconds per phase {dur}, still on the ground "
              f"{tk.still.sum() * tk.dt:.0f}")
    vel = velocity_at_rest(tracks)
    freefall_bound = velocity_in_flight(tracks, vel)
    pos = position(tracks)
    latency(tracks)
    tau_pos = 100.0
    model = {g: (vel[g].variance_ratio, vel[g].correlated_fraction, vel[g].tau_s) for g in ("vel H", "vel D")}
    model.update({g: (pos[g]["diffusion"] * tau_pos, 1.0, tau_pos) for g in ("pos H", "pos D")})
    if not args.skip_fits:
        real = fits(args.seeds, model)
        imu_check(real["fs2-chicago"])
    print("\nRecommended defaults (first-order GM on top of the reported sigma; r scales sigma^2, so the "
          "model's sigma is sqrt(r) x hAcc / vAcc / sAcc):")
    for g in ("pos H", "pos D", "vel H", "vel D"):
        r, f, tau = model[g]
        extra = (f"; in freefall r <= {freefall_bound[g]:.2g} (V2, dynamics included)" if g.startswith("vel")
                 else "; tau chosen, r = tau x diffusion")
        print(f"  {g}: f {f:4.2f}  tau {tau:5.3g} s  r {r:5.2g} (sigma x {np.sqrt(r):.2g}){extra}")
    print("  position: f = 1 (white part below 0.1 %); no levelling off up to 160 s, so tau is a choice "
          "(>= the longest fit) and only r / tau is measured")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
