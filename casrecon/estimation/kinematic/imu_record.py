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
