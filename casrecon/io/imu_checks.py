"""Plausibility rules for an IMU log, in one place: the pre-solve data check of the fits
(:mod:`casrecon.estimation.validation.data_checks`) refuses a log that breaks one, ``casrecon inspect`` warns.

Each rule looks at a span of samples (the fit window, or the whole log for ``inspect``) and returns
a :class:`Finding` (message, line of the IMU CSV, column) or None. The thresholds:

- **gaps** (:data:`IMU_GAP_FACTOR` = 1.5): a step between two samples longer than 1.5 times the
  median step is a gap. The collocation mesh puts sample ``k`` of the window at ``t0 + k dt``, so a
  single missing sample already shifts every later sample by one period; steps quantised to a
  timer tick (400 Hz stamped in whole ms: 2, 3, 2, 3 ms) stay below 1.5 periods.
- **gyro unit** (:data:`MAX_GYRO_RATE_DPS` = 2000 deg/s at the :data:`GYRO_RATE_PERCENTILE` = 95th
  percentile of the angular-rate magnitude): beyond the largest range of common MEMS gyros,
  sustained over 5 % of the span: a log in deg/s declared as rad/s reads 57.3 times too fast
  (drop 3 of the EES problems: 54 deg/s becomes 3100 deg/s). A log in rad/s declared as deg/s
  reads too slow and is not caught by this rule, but by the next.
- **gyros against the accelerometers** (:data:`FORCE_TURN_FACTOR` = 3, :data:`FORCE_TURN_ALLOWANCE_DEG`
  = 90 deg, over blocks of :data:`FORCE_BLOCK_S` = 0.1 s whose mean specific force exceeds
  :data:`FORCE_MIN_G` = 0.5 g): the specific force seen in IMU axes can only turn when the body
  turns (the gyros) or when the force turns in space (drag following the velocity: a drop's path
  bends by at most 90 deg). So the angle the mean specific-force direction sweeps block to block
  must stay within 3 times the angle the gyros sweep (the integral of the rate magnitude) plus
  90 deg. Measured: 0.22 to 0.32 times on the EES drops' fit windows, 0.03 on the spinning
  davinci-ztu, 1.5 to 1.6 on the FlySight 2 skydive (its span, its whole log), 0.4 on the rocket
  Hedy; gyros in rad/s declared as deg/s (57.3 times too small) give 13 to 18 times on the EES
  drops. A body spinning about its specific-force axis (davinci-ztu: 1.7 times) escapes: the spin
  does not turn the force.
- **accelerometer unit** (:data:`ACCEL_MEDIAN_G` = 0.25 to 4 g for the median specific-force
  magnitude over the whole log): a body hanging under a helicopter, sitting on the ground or
  descending at terminal speed feels about 1 g, so the median is near 1 g; m/s^2 declared as g
  gives about 9.8 g, g declared as m/s^2 about 0.1 g.
- **saturation** (:data:`MAX_SATURATED_SHARE` = 25 % of the samples of one axis at or beyond its
  declared limit): the fit leaves saturated samples out; a quarter of an axis clipped means a
  clipped sensor or limits declared in the wrong unit.
- **stuck channel** (:data:`STUCK_RUN_S` = 1 s, at least :data:`STUCK_MIN_SAMPLES` = 20 samples):
  the same reading, not at a declared limit, repeated for 1 s. A working sensor's noise changes
  its reading from sample to sample.

One more rule only warns (:func:`unit_warnings`: ``casrecon inspect`` prints it, the 6-DOF fit logs
it), as a single sample can be a glitch:

- **peak** (:data:`MAX_GYRO_PEAK_RADPS` = 50 rad/s, 2865 deg/s; :data:`MAX_ACCEL_PEAK_MPS2` =
  2000 m/s^2, 204 g): any sample beyond it is implausible for the declared unit. It catches a log
  in deg/s read as rad/s that spends most of its time at rest (the gyro-unit rule looks at the
  95th percentile): a FlySight or a rocket resting for minutes, then tumbling at 200 deg/s, reads
  as 11,000 deg/s.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io.errors import InputError
from casrecon.io.imu import ACCEL_SCALE, GYRO_SCALE, STANDARD_GRAVITY, ImuCsvSpec, ImuLog

IMU_GAP_FACTOR = 1.5
MAX_GYRO_RATE_DPS = 2000.0
GYRO_RATE_PERCENTILE = 95.0
ACCEL_MEDIAN_G = (0.25, 4.0)
MAX_SATURATED_SHARE = 0.25
STUCK_RUN_S = 1.0
STUCK_MIN_SAMPLES = 20
MAX_GYRO_PEAK_RADPS = 50.0
MAX_ACCEL_PEAK_MPS2 = 2000.0
FORCE_TURN_FACTOR = 3.0
FORCE_TURN_ALLOWANCE_DEG = 90.0
FORCE_BLOCK_S = 0.1
FORCE_MIN_G = 0.5
#: Fewest blocks (of FORCE_BLOCK_S, above FORCE_MIN_G) the gyro-against-accelerometer rule needs.
FORCE_MIN_BLOCKS = 20


@dataclass(frozen=True)
class Finding:
    """One broken rule: what is wrong (one sentence), the 1-based line of the IMU CSV and the column."""

    message: str
    line: int | None = None
    field: str | None = None

    def error(self, path: str | Path) -> InputError:
        """The located error for file ``path``."""
        return InputError(path, self.message, line=self.line, field=self.field)


def line_of(index: int, m: ImuLog | None = None) -> int:
    """Line of the file holding sample ``index`` (0-based): ``m.line_numbers`` when the log has them, else
    the IMU CSV's (the header is line 1)."""
    if m is not None and m.line_numbers is not None:
        return int(m.line_numbers[index])
    return int(index) + 2


def _axis_names(spec: ImuCsvSpec, columns: tuple[str, str, str]) -> tuple[str, ...]:
    """Names of the IMU axes for messages: the file's columns, unless an axes rotation mixes them."""
    return columns if spec.axes is None else tuple(f"IMU {a} axis ({', '.join(columns)})" for a in "xyz")


def gap_finding(m: ImuLog, spec: ImuCsvSpec, span: slice = slice(None)) -> Finding | None:
    """The largest step between samples of ``span`` when it exceeds IMU_GAP_FACTOR median steps."""
    idx = np.arange(m.n)[span]
    if idx.size < 3:
        return None
    t = m.time_s[idx]
    step = np.diff(t)
    med = float(np.median(step))
    k = int(np.argmax(step))
    if step[k] <= IMU_GAP_FACTOR * med:
        return None
    n_gaps = int(np.count_nonzero(step > IMU_GAP_FACTOR * med))
    more = f" ({n_gaps} such gaps in all)" if n_gaps > 1 else ""
    return Finding(f"gap of {step[k]:.4g} s after t = {t[k]:.6g} s ({step[k] / med:.1f} sample periods of "
                   f"{med * 1e3:.4g} ms){more}; expected evenly spaced samples, steps at most {IMU_GAP_FACTOR:g} "
                   "periods (the fit places sample k at t0 + k dt)", line=line_of(idx[k + 1], m),
                   field=spec.time_column)


def gyro_unit_finding(m: ImuLog, spec: ImuCsvSpec, span: slice = slice(None)) -> Finding | None:
    """Angular rates beyond what a gyro measures over more than 5 % of ``span``: a unit declared wrong."""
    gyro = m.gyro_radps[span]
    if gyro.shape[0] == 0:
        return None
    rate = np.degrees(np.linalg.norm(gyro, axis=1))
    level = float(np.percentile(rate, GYRO_RATE_PERCENTILE))
    if level <= MAX_GYRO_RATE_DPS:
        return None
    axis = int(np.argmax(np.percentile(np.abs(gyro), GYRO_RATE_PERCENTILE, axis=0)))
    hint = ('the file is probably in deg/s: declare gyro_unit = "deg/s"' if spec.gyro_unit == "rad/s"
            else "check gyro_unit and the gyro columns")
    return Finding(f"angular rate above {level:.0f} deg/s for {100 - GYRO_RATE_PERCENTILE:g} % of the samples (up "
                   f"to {rate.max():.0f} deg/s) with the gyros read as {spec.gyro_unit}; expected at most "
                   f"{MAX_GYRO_RATE_DPS:g} deg/s, the range of a gyro; {hint}",
                   field=_axis_names(spec, spec.gyro_columns)[axis])


def _block_means(t: np.ndarray, x: np.ndarray, block_s: float) -> np.ndarray:
    """Means of the rows of ``x`` over consecutive blocks of ``block_s`` of ``t`` (empty blocks left out)."""
    k = np.floor((t - t[0]) / block_s).astype(np.int64)
    count = np.bincount(k)
    sums = np.column_stack([np.bincount(k, x[:, j], minlength=count.size) for j in range(x.shape[1])])
    full = count > 0
    return sums[full] / count[full, None]


def force_turn(m: ImuLog, span: slice = slice(None)) -> tuple[float, float, int]:
    """Angles (deg) swept over ``span`` by the mean specific-force direction in IMU axes and by the
    gyros (the integral of the rate magnitude), summed over consecutive blocks of FORCE_BLOCK_S (at
    least two samples) whose mean specific force exceeds FORCE_MIN_G; and the number of such steps."""
    t = m.time_s[span]
    if t.size < 4:
        return 0.0, 0.0, 0
    block = max(FORCE_BLOCK_S, 2.0 * float(np.median(np.diff(t))))
    f = _block_means(t, m.accel_mps2[span], block)
    rate = np.linalg.norm(_block_means(t, m.gyro_radps[span], block), axis=1)
    mag = np.linalg.norm(f, axis=1)
    strong = mag > FORCE_MIN_G * STANDARD_GRAVITY
    pair = strong[1:] & strong[:-1]
    u = f / np.where(mag > 0, mag, 1.0)[:, None]
    swept = np.degrees(np.arccos(np.clip(np.sum(u[1:] * u[:-1], axis=1), -1.0, 1.0)))
    turned = np.degrees(0.5 * (rate[1:] + rate[:-1])) * block
    return float(swept[pair].sum()), float(turned[pair].sum()), int(pair.sum())


def gyro_scale_finding(m: ImuLog, spec: ImuCsvSpec, span: slice = slice(None)) -> Finding | None:
    """The specific force turning in IMU axes by more than the gyros allow (FORCE_TURN_FACTOR times
    their angle plus FORCE_TURN_ALLOWANCE_DEG): gyros reading too slow, as rad/s declared as deg/s."""
    swept, turned, n = force_turn(m, span)
    allowed = FORCE_TURN_FACTOR * turned + FORCE_TURN_ALLOWANCE_DEG
    if n < FORCE_MIN_BLOCKS or swept <= allowed:
        return None
    if spec.gyro_unit == "deg/s" and swept <= FORCE_TURN_FACTOR * np.degrees(turned) + FORCE_TURN_ALLOWANCE_DEG:
        hint = (f'in rad/s the gyros would turn {np.degrees(turned):.0f} deg, enough: the file is probably in '
                'rad/s, declare gyro_unit = "rad/s"')
    else:
        hint = "check gyro_unit, the gyro columns and a scale factor applied to them"
    t = m.time_s[span]
    return Finding(f"the specific force turned {swept:.0f} deg in IMU axes from t = {t[0]:.6g} to {t[-1]:.6g} s "
                   f"({n} steps of {max(FORCE_BLOCK_S, 2 * float(np.median(np.diff(t)))):.3g} s above "
                   f"{FORCE_MIN_G:g} g) while the gyros, read as {spec.gyro_unit}, turned {turned:.0f} deg; expected "
                   f"at most {FORCE_TURN_FACTOR:g} x {turned:.0f} + {FORCE_TURN_ALLOWANCE_DEG:g} = {allowed:.0f} deg "
                   f"(the force turns in IMU axes only as the body turns, or as the path bends); {hint}",
                   field=",".join(spec.gyro_columns))


def accel_unit_finding(m: ImuLog, spec: ImuCsvSpec) -> Finding | None:
    """Median specific force of the whole log outside ACCEL_MEDIAN_G: an accelerometer unit declared wrong."""
    med = float(np.median(np.linalg.norm(m.accel_mps2, axis=1))) / STANDARD_GRAVITY
    lo, hi = ACCEL_MEDIAN_G
    if lo <= med <= hi:
        return None
    if med > hi and spec.accel_unit == "g":
        hint = 'the file is probably in m/s^2: declare accel_unit = "m/s^2"'
    elif med < lo and spec.accel_unit == "m/s^2":
        hint = 'the file is probably in g: declare accel_unit = "g"'
    else:
        hint = "check accel_unit and the accelerometer columns"
    return Finding(f"median specific force over the log {med:.3g} g with the accelerometers read as "
                   f"{spec.accel_unit}; expected {lo:g} to {hi:g} g (a body hanging, at rest or descending at "
                   f"terminal speed feels about 1 g); {hint}", field=",".join(spec.accel_columns))


def saturation_finding(m: ImuLog, spec: ImuCsvSpec, span: slice = slice(None)) -> Finding | None:
    """An axis with more than MAX_SATURATED_SHARE of the samples of ``span`` at its declared limit."""
    for kind, sat, columns, unit, limits in (
            ("gyro", m.gyro_saturated, spec.gyro_columns, spec.gyro_unit, spec.gyro_limits),
            ("accelerometer", m.accel_saturated, spec.accel_columns, spec.accel_unit, spec.accel_limits)):
        part = sat[span]
        if part.shape[0] == 0 or limits is None:
            continue
        share = part.mean(axis=0)
        k = int(np.argmax(share))
        if share[k] > MAX_SATURATED_SHARE:
            idx = np.arange(m.n)[span][part[:, k]]
            return Finding(f"{share[k]:.0%} of the {kind} samples at or beyond the declared {kind} limits "
                           f"({_limits_text(limits, k, unit)}), from t = {m.time_s[idx[0]]:.6g} s; expected at most "
                           f"{MAX_SATURATED_SHARE:.0%} (a clipped sensor, or limits or unit declared wrong)",
                           line=line_of(idx[0], m), field=_axis_names(spec, columns)[k])
    return None


def _limits_text(limits: tuple[tuple[float, float], ...], k: int, unit: str) -> str:
    pairs = np.broadcast_to(np.array(limits, dtype=np.float64).reshape(-1, 2), (3, 2))
    return f"{pairs[k, 0]:g} to {pairs[k, 1]:g} {unit}"


def _longest_run(v: np.ndarray, free: np.ndarray) -> tuple[int, int]:
    """(start, length) of the longest run of equal consecutive values of ``v`` where ``free`` holds."""
    same = (v[1:] == v[:-1]) & free[1:] & free[:-1]
    if not same.any():
        return 0, 1
    edges = np.flatnonzero(np.diff(np.r_[0, same.astype(np.int8), 0]))
    starts, stops = edges[::2], edges[1::2]
    j = int(np.argmax(stops - starts))
    return int(starts[j]), int(stops[j] - starts[j]) + 1


def stuck_finding(m: ImuLog, spec: ImuCsvSpec, span: slice = slice(None)) -> Finding | None:
    """A channel repeating one reading (not at a declared limit) for STUCK_RUN_S or longer within ``span``."""
    idx = np.arange(m.n)[span]
    if idx.size < STUCK_MIN_SAMPLES:
        return None
    t = m.time_s[idx]
    for kind, values, sat, columns, scale, unit in (
            ("gyro", m.gyro_radps, m.gyro_saturated, spec.gyro_columns, GYRO_SCALE[spec.gyro_unit], spec.gyro_unit),
            ("accelerometer", m.accel_mps2, m.accel_saturated, spec.accel_columns, ACCEL_SCALE[spec.accel_unit],
             spec.accel_unit)):
        for k in range(3):
            start, n = _longest_run(values[idx, k], ~sat[idx, k])
            duration = float(t[start + n - 1] - t[start])
            if n >= STUCK_MIN_SAMPLES and duration >= STUCK_RUN_S:
                return Finding(f"{kind} reads {values[idx[start], k] / scale:.6g} {unit} for {duration:.4g} s "
                               f"({n} samples from t = {t[start]:.6g} s); expected a reading that changes (a working "
                               f"sensor's noise changes it from sample to sample; unchanged for {STUCK_RUN_S:g} s or "
                               "longer means a stuck or disconnected channel, or clipping at undeclared limits)",
                               line=line_of(idx[start], m), field=_axis_names(spec, columns)[k])
    return None


def imu_findings(m: ImuLog, spec: ImuCsvSpec, span: slice = slice(None)) -> list[Finding]:
    """Every rule's finding on ``span`` (the accelerometer unit on the whole log), in the order the fit checks."""
    found = [gap_finding(m, spec, span), accel_unit_finding(m, spec), gyro_unit_finding(m, spec, span),
             saturation_finding(m, spec, span), stuck_finding(m, spec, span), gyro_scale_finding(m, spec, span)]
    return [f for f in found if f is not None]


def peak_findings(m: ImuLog, spec: ImuCsvSpec, span: slice = slice(None)) -> dict[str, Finding]:
    """The largest gyro and accelerometer sample of ``span``, each when beyond its plausible peak
    (MAX_GYRO_PEAK_RADPS, MAX_ACCEL_PEAK_MPS2), naming the column, the value and the likely unit;
    keyed by "gyro" and "accelerometer"."""
    out = {}
    for kind, values, columns, unit, scale, limit, si in (
            ("gyro", m.gyro_radps, spec.gyro_columns, spec.gyro_unit, GYRO_SCALE[spec.gyro_unit],
             MAX_GYRO_PEAK_RADPS, "rad/s"),
            ("accelerometer", m.accel_mps2, spec.accel_columns, spec.accel_unit, ACCEL_SCALE[spec.accel_unit],
             MAX_ACCEL_PEAK_MPS2, "m/s^2")):
        part = np.abs(values[span])
        if part.size == 0 or part.max() <= limit:
            continue
        i, k = np.unravel_index(int(np.argmax(part)), part.shape)
        idx = int(np.arange(m.n)[span][i])
        raw = float(values[idx, k]) / scale
        if kind == "gyro" and unit == "rad/s":
            hint = (f'in deg/s it would be {raw:.4g} deg/s, a plausible rate: the file is probably in deg/s, '
                    'declare gyro_unit = "deg/s"')
        elif kind == "accelerometer" and unit == "g":
            hint = (f'in m/s^2 it would be {raw:.4g} m/s^2 ({raw / STANDARD_GRAVITY:.3g} g): the file is probably '
                    'in m/s^2, declare accel_unit = "m/s^2"')
        else:
            hint = f"check {'gyro' if kind == 'gyro' else 'accel'}_unit and the {kind} columns"
        v = float(values[idx, k])
        if kind == "gyro":
            other = f"{np.degrees(v):.0f} deg/s" if unit == "rad/s" else f"{v:.1f} rad/s"
        else:
            other = f"{v / STANDARD_GRAVITY:.0f} g" if unit == "m/s^2" else f"{v:.0f} m/s^2"
        out[kind] = Finding(f"{kind} reads {raw:.6g} {unit} ({other}) at t = {m.time_s[idx]:.6g} s "
                            f"with the {kind}s read as {unit}; beyond {limit:g} {si}, implausible for a {kind}; {hint}",
                            line=line_of(idx, m), field=_axis_names(spec, columns)[k])
    return out


def unit_warnings(m: ImuLog, spec: ImuCsvSpec, span: slice = slice(None)) -> list[Finding]:
    """The peak findings of ``span`` of the kinds whose unit rule (gyro_unit_finding,
    accel_unit_finding) does not already flag them."""
    flagged = {"gyro": gyro_unit_finding(m, spec, span) is not None,
               "accelerometer": accel_unit_finding(m, spec) is not None}
    return [f for kind, f in peak_findings(m, spec, span).items() if not flagged[kind]]
