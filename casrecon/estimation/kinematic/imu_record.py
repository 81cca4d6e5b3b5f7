"""The IMU record of a kinematic problem as its fit takes it: read from a FlySight 2 SENSOR.CSV or an
IMU CSV onto the common clock, saturated samples flagged against ``[imu] accel_limits`` /
``gyro_limits``, and the span reconstructed checked and described like the 6-DOF fit's IMU
(:mod:`casrecon.io.imu_checks`):

- **saturation**: a sample at or beyond its axis's limit (in the file's units: a CSV's
  ``accel_unit`` / ``gyro_unit``, g and deg/s for a SENSOR.CSV) is masked: the fit bridges it by
  linear interpolation between the axis's nearest valid samples and gives it a large noise
  (``KinematicOptions.saturated_gyro_sigma_radps``, ``saturated_accel_sigma_mps2``); the masked
  axis-samples of the span are counted in a note. More than 25 % of an axis's samples of the span
  at its limit is refused (:func:`~casrecon.io.imu_checks.saturation_finding`: a clipped sensor, or
  limits or unit declared wrong).
- **gaps**: a step between samples over :data:`~casrecon.io.imu_checks.IMU_GAP_FACTOR` (1.5) median
  sample periods is a gap. The 6-DOF fit refuses any (its mesh places sample k at t0 + k dt); the
  kinematic preintegration takes the samples at their own times, each governing the time to the
  midpoints with its neighbours, so a short gap is bridged by its neighbouring samples and the gaps
  are counted in a note (number, longest, its time and line). A gap longer than
  :data:`MAX_IMU_GAP_S` is refused with its line: the motion over it is not measured.
- **aliased stretches** (:func:`aliased_samples`): where the rate changes so much between two
  consecutive samples that the turns over the step between them, taken from one sample's rate or
  from the other's, differ by more than :data:`MAX_TURN_DIFFERENCE_RAD` (0.25 rad, 14.3 deg), the
  samples do not resolve the rotation (it is aliased: the path between them could be any): a
  parachute's opening shock sampled at 13 Hz. Such steps closer than :data:`ALIASED_JOIN_S` make
  one stretch, from the first step's first sample to the last step's second; its samples keep
  their values but are weighted with the saturated-sample noise (gyros and accelerometers: the
  specific force is sampled as coarsely and turned by the unresolved rotation), and a note names
  each stretch's times and lines (however many: a record aliased over most of its span leaves the
  attitude to the fixes, and the note says where). A sample turning more than 1 rad is refused by
  the rate rule below.
- **rate** (:func:`check_piece_rotation`, run by the fit on the bridged record): more than
  ``MAX_PIECE_ROTATION_RAD`` (1 rad, 57 deg) of turn over one sample's time is refused as bad input
  (exit status 2) naming the file and the sample's line: a rate too low for the body's rotation, or
  a gyro unit declared wrong.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from casrecon.estimation.kinematic.data import KinematicData
from casrecon.io.errors import InputError
from casrecon.io.imu import ACCEL_SCALE, GYRO_SCALE, ImuCsvSpec, ImuLog, read_imu_csv, saturation_mask
from casrecon.io.imu_checks import IMU_GAP_FACTOR, line_of, saturation_finding
from casrecon.io.kinematic_problem import KinematicImu
from casrecon.io.sensor import read_flysight2_sensor
from casrecon.physics.preintegration import MAX_PIECE_ROTATION_RAD

#: Longest gap between IMU samples the kinematic fit bridges, s: the fit's default node spacing
#: (``[estimation] max_node_spacing_s``), so a longer gap leaves a whole interval of the mesh
#: without a sample of its own; at a skydiver's 100 deg/s, 50 deg of turn unmeasured.
MAX_IMU_GAP_S = 0.5
#: Largest difference between the turns over one step between samples taken from either sample's
#: rate, |w[k+1] - w[k]| (t[k+1] - t[k]), rad, before the step counts as aliased. Measured: the
#: shipped FlySight 2 jump (13 Hz) reaches 0.18 rad (10.1 deg) in the exit's tumble, which its fit
#: resolves (over the first 40 s every IMU parameter stays within 1 prior sigma), and 0.95 rad
#: (54.7 deg) in the canopy opening, whose samples bent the gyro scale z to +5.9 sigma; the rocket
#: drogue record (100 Hz, spinning at 20 rad/s) 0.017 rad. A judgment between them, not a derived bound.
MAX_TURN_DIFFERENCE_RAD = 0.25
#: Aliased steps less than this apart (s) are one stretch: the fit's default node spacing, so no
#: clean piece shorter than a node interval is left between two aliased ones.
ALIASED_JOIN_S = 0.5
#: How many stretches a note names one by one.
NAMED_STRETCHES = 5
#: How a FlySight 2 SENSOR.CSV's IMU rows are named and in which units its limits are given.
SENSOR_COLUMNS = {"time_column": "time", "accel_columns": ("ax", "ay", "az"), "gyro_columns": ("wx", "wy", "wz"),
                  "accel_unit": "g", "gyro_unit": "deg/s"}


@dataclass(frozen=True)
class ImuRecord:
    """An IMU record on the common clock.

    Attributes
    ----------
    log : ImuLog
        Samples (SI, IMU axes) at their common-clock times (s), saturation flags, and the line of
        each sample in its file.
    spec : ImuCsvSpec
        Column names, units and saturation limits as the file writes them (for messages).
    notes : tuple of str
        What the reader noted (a SENSOR.CSV's dropped ``$TIME`` rows).
    """

    log: ImuLog
    spec: ImuCsvSpec
    notes: tuple[str, ...] = ()


def read_imu_record(imu: KinematicImu) -> ImuRecord:
    """Read the IMU file of ``imu`` (SENSOR.CSV when ``imu.spec`` is None) onto the common clock, with
    the saturation flags of ``imu.accel_limits`` / ``imu.gyro_limits``.

    Raises
    ------
    InputError
        A file that cannot be read (located).
    """
    if imu.spec is not None:
        csv = read_imu_csv(imu.file, imu.spec)
        return ImuRecord(replace(csv, time_s=csv.time_s + imu.utc_at_zero_s), imu.spec)
    sensor = read_flysight2_sensor(imu.file)
    spec = ImuCsvSpec(**SENSOR_COLUMNS, accel_limits=imu.accel_limits, gyro_limits=imu.gyro_limits)
    accel, gyro = sensor.imu_accel_mps2, sensor.imu_gyro_radps
    log = ImuLog(str(imu.file), sensor.imu_time_unix_s, accel, gyro,
                 saturation_mask(accel / ACCEL_SCALE[spec.accel_unit], spec.accel_limits),
                 saturation_mask(gyro / GYRO_SCALE[spec.gyro_unit], spec.gyro_limits), sensor.imu_lines)
    notes = (sensor.clock_fit.dropped_note(),) if sensor.clock_fit.dropped else ()
    return ImuRecord(log, spec, notes)


def check_span(record: ImuRecord, start_s: float, end_s: float) -> tuple[str, ...]:
    """Check the samples from ``start_s`` to ``end_s`` (common clock, s) per the module's rules and
    describe them: the notes on their saturated samples and gaps (none when there are none).

    Raises
    ------
    InputError
        An axis saturated over more than a quarter of the span, or a gap longer than
        :data:`MAX_IMU_GAP_S`; located by the file's line.
    """
    m, spec = record.log, record.spec
    span = slice(int(np.searchsorted(m.time_s, start_s)), int(np.searchsorted(m.time_s, end_s, side="right")))
    found = saturation_finding(m, spec, span)
    if found is not None:
        raise found.error(m.path)
    notes = []
    for kind, sat, key in (("gyro", m.gyro_saturated, "gyro_limits"), ("accelerometer", m.accel_saturated,
                                                                       "accel_limits")):
        n = int(sat[span].sum())
        if n:
            notes.append(f"{n} saturated {kind} axis-samples in the span (at or beyond [imu] {key}) masked: "
                         "bridged by linear interpolation and weighted with the saturated-sample noise")
    gap = gap_note(m, spec, span)
    return tuple(notes) + ((gap,) if gap else ())


def gap_note(m: ImuLog, spec: ImuCsvSpec, span: slice) -> str:
    """The note on the gaps of ``span`` ("" when none); a located InputError for one over MAX_IMU_GAP_S."""
    idx = np.arange(m.n)[span]
    if idx.size < 3:
        return ""
    t = m.time_s[idx]
    step = np.diff(t)
    med = float(np.median(step))
    gaps = np.flatnonzero(step > IMU_GAP_FACTOR * med)
    if not gaps.size:
        return ""
    k = int(gaps[np.argmax(step[gaps])])
    line = line_of(idx[k + 1], m)
    if step[k] > MAX_IMU_GAP_S:
        raise InputError(m.path, f"gap of {step[k]:.3g} s between IMU samples after t = {t[k]:.3f} s; expected gaps of "
                         f"at most "
                         f"{MAX_IMU_GAP_S:g} s in the span reconstructed (the motion over a longer one is not "
                         "measured): choose a [segment] without it", line=line, field=spec.time_column)
    plural = "s" if gaps.size > 1 else ""
    return (f"{gaps.size} gap{plural} in the IMU record over the span (steps over {IMU_GAP_FACTOR:g} sample periods of "
            f"{med * 1e3:.4g} ms; {float(step[gaps].sum()):.3g} s in all), the longest {step[k]:.3g} s after "
            f"t = {t[k]:.3f} s (line {line}): each bridged by its neighbouring samples (none invented)")


def check_piece_rotation(data: KinematicData, gyro: np.ndarray) -> None:
    """Refuse an IMU record that turns more than MAX_PIECE_ROTATION_RAD over one sample's time: bad
    input (a rate too low for the body, or a gyro unit declared wrong), an InputError naming the file
    and the sample's line where known."""
    dt = np.gradient(data.imu_time_s)
    turn = np.linalg.norm(gyro, axis=1) * dt
    k = int(np.argmax(turn))
    if turn[k] > MAX_PIECE_ROTATION_RAD:
        lines = data.imu_lines
        line = int(lines[k]) if lines is not None and lines.size == turn.size else None
        raise InputError(data.imu_file or "the IMU record", f"the IMU turns {np.degrees(turn[k]):.0f} deg between "
                         f"samples at t = {data.time_ref_s + data.imu_time_s[k]:.3f} s (more than "
                         f"{np.degrees(MAX_PIECE_ROTATION_RAD):.0f} deg): its rate is too low for the body's rotation, "
                         "or the gyro unit is wrong", line=line)


def aliased_stretches(time_s: np.ndarray, gyro_radps: np.ndarray, limit_rad: float = MAX_TURN_DIFFERENCE_RAD,
                      join_s: float = ALIASED_JOIN_S) -> list[tuple[int, int]]:
    """The stretches of an IMU record whose rotation the sampling does not resolve.

    Parameters
    ----------
    time_s : (N,) array
        Sample times, s, increasing.
    gyro_radps : (N, 3) array
        Angular rates, rad/s.
    limit_rad : float
        A step from sample k to k + 1 is aliased when ``|w[k+1] - w[k]| (t[k+1] - t[k])`` exceeds
        it, rad (:data:`MAX_TURN_DIFFERENCE_RAD`).
    join_s : float
        Aliased steps whose samples are at most this far apart, s, are one stretch.

    Returns
    -------
    list of (int, int)
        First and last sample index (inclusive) of each stretch, in time order; empty when none.
    """
    stretches: list[tuple[int, int]] = []
    for k in np.flatnonzero(turn_differences(time_s, gyro_radps) > limit_rad):
        k = int(k)
        if stretches and time_s[k] - time_s[stretches[-1][1]] <= join_s:
            stretches[-1] = (stretches[-1][0], k + 1)
        else:
            stretches.append((k, k + 1))
    return stretches


def turn_differences(time_s: np.ndarray, gyro_radps: np.ndarray) -> np.ndarray:
    """Per step between consecutive samples, the difference between the turns over it taken from
    either sample's rate, ``|w[k+1] - w[k]| (t[k+1] - t[k])``, rad ((N - 1,); empty for N < 2)."""
    return np.linalg.norm(np.diff(gyro_radps, axis=0), axis=1) * np.diff(time_s)


def aliased_samples(record: ImuRecord, start_s: float, end_s: float) -> tuple[np.ndarray, tuple[str, ...]]:
    """The samples from ``start_s`` to ``end_s`` (common clock, s) in aliased stretches
    (:func:`aliased_stretches`) and the note naming them.

    Returns
    -------
    aliased : (n,) bool array
        For each sample of the span, True when it lies in an aliased stretch.
    notes : tuple of str
        One note naming the stretches' times, lines and largest turn difference (none when none).
    """
    m = record.log
    span = slice(int(np.searchsorted(m.time_s, start_s)), int(np.searchsorted(m.time_s, end_s, side="right")))
    t, gyro = m.time_s[span], m.gyro_radps[span]
    aliased = np.zeros(t.size, bool)
    stretches = aliased_stretches(t, gyro)
    if not stretches:
        return aliased, ()
    for a, b in stretches:
        aliased[a:b + 1] = True
    worst = float(np.max(turn_differences(t, gyro)))
    limit = (f"the rate changes between consecutive samples by more than {np.degrees(MAX_TURN_DIFFERENCE_RAD):.1f} "
             f"deg of turn over the step, up to {np.degrees(worst):.1f} deg")
    named = [f"t = {t[a]:.3f} to {t[b]:.3f} s (lines {line_of(span.start + a, m)} to {line_of(span.start + b, m)})"
             for a, b in stretches[:NAMED_STRETCHES]]
    more = f" and {len(stretches) - NAMED_STRETCHES} more" if len(stretches) > NAMED_STRETCHES else ""
    stretch = "stretches" if len(stretches) > 1 else "stretch"
    return aliased, (f"{int(aliased.sum())} IMU samples in {len(stretches)} {stretch} whose "
                     f"rotation the sampling does not resolve ({limit}: aliased, as in a parachute's opening "
                     f"shock): {', '.join(named)}{more}; their gyro and accelerometer values kept and weighted "
                     "with the saturated-sample noise",)
