"""Figures of the input data (the EES paper's Figs. 6, 7 and 9): the IMU's specific force and rates,
the GPS track with its accuracies and satellites, and the sounding's wind, temperature and density.

Two uses: ``casrecon inspect FILE --plot OUT.png`` (:func:`plot_input_file`, any supported IMU CSV,
FlySight track or sounding, against the file's own time), and the ``inputs_imu``, ``inputs_gps`` and
``inputs_sounding`` figures of a results folder (:data:`INPUT_FIGURES`), drawn from the data files
that ``config/resolved.json`` names (``inputs``), against flight time since release with the fit
window shaded and, for the sounding, the drop's altitude range. A folder whose data files have moved
skips those figures with a note.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pymap3d
from matplotlib.figure import Figure

from casrecon.io.errors import InputError
from casrecon.io.flysight import GpsTrack, iso_utc, read_flysight
from casrecon.io.imu import ACCEL_SCALE, GYRO_SCALE, ImuCsvSpec, ImuLog, read_imu_csv
from casrecon.io.input_kind import input_kind
from casrecon.io.sounding import read_sounding
from casrecon.io.sounding_levels import Sounding
from casrecon.physics.atmosphere import Atmosphere
from casrecon.report import figure_style as style
from casrecon.report.figure_layout import log_axis
from casrecon.report.results_folder import DropFolder, MissingInput

#: Where a results folder records its data files.
RESOLVED = "config/resolved.json"
AXES = "xyz"
#: Mathtext of the IMU units.
UNIT_LABELS = {"m/s^2": style.MPS2, "g": "g", "deg/s": "deg/s", "rad/s": "rad/s"}
#: Shade of the fit window and the drop's altitude range.
SHADE = "0.9"


@dataclass(frozen=True)
class Timeline:
    """How to put a file's times on the plotted time axis, and what to mark on it.

    ``offset_s`` is subtracted from the file's times (IMU clock s, or UTC Unix s for GPS);
    ``window_s`` (start, end) and ``events`` ({label: time}) are on the plotted axis.
    """

    label: str
    offset_s: float = 0.0
    window_s: tuple[float, float] | None = None
    events: tuple[tuple[str, float], ...] = ()


def _mark(ax, timeline: Timeline) -> None:
    if timeline.window_s is not None:
        ax.axvspan(*timeline.window_s, color=SHADE, zorder=0, label="fit window")
    for (label, t), ls in zip(timeline.events, ("-.", ":", "--")):
        ax.axvline(t, color=style.SIGMA_COLOR, lw=1.0, ls=ls, label=label)


def imu_figure(log: ImuLog, title: str, timeline: Timeline, accel_unit: str = "m/s^2",
               gyro_unit: str = "deg/s", spec: ImuCsvSpec | None = None) -> Figure:
    """Specific force and angular rate of an IMU log (IMU axes) against time, one panel per channel,
    in ``accel_unit`` and ``gyro_unit``; saturated samples marked, the saturation limits of ``spec``
    (in the file's units) drawn as dashed lines where they fall inside the y range. With a fit
    window the y range is that of the window's samples (so the impact does not squash the flight)."""
    t = log.time_s - timeline.offset_s
    span = np.ones(t.size, bool) if timeline.window_s is None else (
        (t >= timeline.window_s[0]) & (t <= timeline.window_s[1]))
    span = span if span.any() else np.ones(t.size, bool)
    fig, axes = style.new_figure(3, 2, (13, 8.5), fixed=True)
    accel_scale, gyro_scale = ACCEL_SCALE[accel_unit], GYRO_SCALE[gyro_unit]
    units = UNIT_LABELS
    for k in range(3):
        for col, (values, sat, scale, unit, sym, limits) in enumerate((
                (log.accel_mps2, log.accel_saturated, accel_scale, accel_unit, "f", spec and spec.accel_limits),
                (log.gyro_radps, log.gyro_saturated, gyro_scale, gyro_unit, r"\omega", spec and spec.gyro_limits))):
            ax = axes[k, col]
            _mark(ax, timeline)
            y = values[:, k] / scale
            ax.plot(*style.decimate(t, y), color=style.MEASUREMENT_COLOR, lw=0.7, label="measured")
            if sat[:, k].any():
                ax.plot(t[sat[:, k]], y[sat[:, k]], "x", ms=3, color=style.MASKED_COLOR, rasterized=True,
                        label="saturated sample")
            y_lo, y_hi = float(y[span].min()), float(y[span].max())
            pad = 0.08 * (y_hi - y_lo) or 1.0
            if limits:
                for v in limits[k] if len(limits) == 3 else limits[0]:
                    if y_lo - pad <= v <= y_hi + pad:
                        ax.axhline(v, color=style.MASKED_COLOR, lw=0.8, ls="--", label="saturation limit")
            ax.set_ylim(y_lo - pad, y_hi + pad)
            ax.set_ylabel(f"${sym}_{AXES[k]}$, {units[unit]}")
    axes[0, 0].set_title("specific force (accelerometers), IMU axes")
    axes[0, 1].set_title("angular rate (gyros), IMU axes")
    for ax in axes[-1]:
        ax.set_xlabel(timeline.label)
    style.figure_legend(fig)
    fig.suptitle(title)
    return fig


def gps_figure(track: GpsTrack, title: str, timeline: Timeline, origin: tuple[float, float, float] | None = None
               ) -> Figure:
    """GPS track: ground track (m north and east of ``origin`` (lat deg, lon deg, h m), default the
    first fix), height MSL, NED velocity, satellites used, speed accuracy sAcc and position
    accuracies hAcc, vAcc against time."""
    t = track.time_unix_s - timeline.offset_s
    if origin is None:
        origin = (float(track.lat_deg[0]), float(track.lon_deg[0]), float(track.h_msl_m[0]))
    n, e, _ = pymap3d.geodetic2ned(track.lat_deg, track.lon_deg, track.h_msl_m, *origin)
    fig, axes = style.new_figure(2, 3, (15, 8.5), sharex=False, fixed=True)
    for ax in axes.flat[1:]:
        ax.sharex(axes[0, 1])
        _mark(ax, timeline)
    ax = axes[0, 0]
    ax.plot(e, n, "-", color=style.MEASUREMENT_COLOR, lw=0.8)
    ax.plot(e, n, ".", ms=3, color=style.MEASUREMENT_COLOR, label="GPS fix")
    ax.plot(e[:1], n[:1], "o", color=style.RECONSTRUCTED_COLOR, mfc="none", ms=7, label="first fix")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east, m")
    ax.set_ylabel("north, m")
    ax.set_title("ground track")
    axes[0, 1].plot(t, track.h_msl_m, ".-", ms=3, lw=0.8, color=style.MEASUREMENT_COLOR, label="GPS fix")
    axes[0, 1].set_ylabel("height MSL, m")
    for v, ls in ((track.vel_n_mps, "-"), (track.vel_e_mps, "--"), (track.vel_d_mps, ":")):
        axes[0, 2].plot(t, v, ls, lw=1.2, color=style.MEASUREMENT_COLOR)
    axes[0, 2].set_ylabel("velocity, m/s\n(solid north, dashed east, dotted down)")
    sv = track.num_sv >= 0
    axes[1, 0].step(t[sv], track.num_sv[sv], where="post", color=style.MEASUREMENT_COLOR)
    axes[1, 0].set_ylabel("satellites used (numSV)")
    axes[1, 1].plot(t, track.s_acc_mps, color=style.MEASUREMENT_COLOR, lw=1.2)
    axes[1, 1].set_ylabel("speed accuracy sAcc, m/s")
    axes[1, 2].plot(t, track.h_acc_m, "-", color=style.MEASUREMENT_COLOR, lw=1.2)
    axes[1, 2].plot(t, track.v_acc_m, "--", color=style.MEASUREMENT_COLOR, lw=1.2)
    axes[1, 2].set_ylabel("position accuracy, m\n(solid hAcc horizontal, dashed vAcc vertical)")
    for ax in (axes[1, 1], axes[1, 2]):
        log_axis(ax.yaxis, plain=True)
    for ax in axes[1]:
        ax.set_xlabel(timeline.label)
    axes[0, 1].set_xlabel(timeline.label)
    axes[0, 2].set_xlabel(timeline.label)
    style.figure_legend(fig, ncol=6)
    fig.suptitle(title)
    return fig


def sounding_figure(s: Sounding, title: str, drop_range_msl_m: tuple[float, float] | None = None) -> Figure:
    """Wind speed, the direction it blows from, temperature and density (given, or from p, T and
    the dewpoint as the fit's atmosphere makes it) against altitude MSL; ``drop_range_msl_m``
    (ground, release) shaded and used to zoom the altitude axis."""
    h = s.altitude_msl_m
    speed = np.hypot(s.wind_north_mps, s.wind_east_mps)
    direction = np.degrees(np.arctan2(-s.wind_east_mps, -s.wind_north_mps)) % 360.0
    given = s.density_kgm3 is not None
    rho = Atmosphere.from_sounding(s).levels["density_kgm3"]  # the fit's: given, else from p, T and dewpoints
    fig, axes = style.new_figure(1, 4, (15, 6), sharex=False, fixed=True)
    for ax in axes[0, 1:]:
        ax.sharey(axes[0, 0])
    panels = ((speed, "wind speed, m/s", ".-"), (direction, "wind direction (from), deg", "."),
              (s.temperature_k, "temperature, K", ".-"),
              (rho, "density" + ("" if given else (r" $p / (R T)$" if s.dewpoint_k is None else ", moist air"))
               + r", kg/m$^3$", ".-"))
    for ax, (x, label, fmt) in zip(axes[0], panels):
        if drop_range_msl_m is not None:
            ax.axhspan(*drop_range_msl_m, color=SHADE, zorder=0, label="drop (ground to release)")
        ax.plot(x, h, fmt, color=style.MEASUREMENT_COLOR, lw=1.2, ms=4, label="sounding level")
        ax.set_xlabel(label)
    axes[0, 1].set_xlim(0, 360)
    axes[0, 1].set_xticks(range(0, 361, 90))
    axes[0, 0].set_ylabel("altitude MSL, m")
    if drop_range_msl_m is not None:
        lo, hi = drop_range_msl_m
        span = hi - lo
        inside = (h >= lo - 0.3 * span) & (h <= hi + 0.3 * span)
        axes[0, 0].set_ylim(lo - 0.1 * span, hi + 0.3 * span)
        for ax, (x, _, _) in zip(axes[0], panels):
            if inside.any() and ax is not axes[0, 1]:
                lo_x, hi_x = float(np.min(x[inside])), float(np.max(x[inside]))
                pad = 0.1 * (hi_x - lo_x) or 0.05 * abs(hi_x) or 1.0
                ax.set_xlim(lo_x - pad, hi_x + pad)
    style.figure_legend(fig)
    fig.suptitle(title)
    return fig


# ---- a results folder ---------------------------------------------------------------------------------


def _inputs(drop: DropFolder, key: str) -> dict:
    inputs = drop.json(RESOLVED).get("inputs")
    if not inputs or not inputs.get(key) or not inputs[key].get("file"):
        raise MissingInput(f"{RESOLVED} names no {key} file")
    path = Path(inputs[key]["file"])
    if not path.is_file():
        raise MissingInput(f"the {key} file {path} named in {RESOLVED} is not there any more")
    return inputs


def _window(drop: DropFolder) -> tuple[float, float] | None:
    window = drop.summary.get("window_imu_s")
    return None if not window else (window[0] - drop.release_imu_s, window[1] - drop.release_imu_s)


def _events(drop: DropFolder) -> tuple[tuple[str, float], ...]:
    impact = drop.summary.get("impact_imu_s")
    events = (("release", 0.0),)
    return events + ((("impact", impact - drop.release_imu_s),) if impact is not None else ())


def _tupled(value):
    return tuple(_tupled(v) for v in value) if isinstance(value, list) else value


def inputs_imu_figure(drop: DropFolder) -> Figure:
    """The fit's IMU file in its own units against flight time, fit window shaded."""
    rec = _inputs(drop, "imu")["imu"]
    spec = ImuCsvSpec(**{k: _tupled(v) for k, v in rec["spec"].items()})
    log = read_imu_csv(rec["file"], spec)
    timeline = Timeline(style.FLIGHT_TIME_LABEL, drop.release_imu_s, _window(drop), _events(drop))
    return imu_figure(log, f"{drop.name}: IMU data ({Path(rec['file']).name})", timeline,
                      spec.accel_unit, spec.gyro_unit, spec)


def _clock_offset_s(drop: DropFolder) -> float:
    try:
        return float(drop.json("parameters.json")["parameters"]["clock_offset_s"]["value"])
    except (MissingInput, KeyError, TypeError):
        return 0.0


def inputs_gps_figure(drop: DropFolder) -> Figure:
    """The fit's GPS file against flight time (UTC put on the IMU clock with the fitted clock
    offset), ground track from the site, fit window shaded."""
    inputs = _inputs(drop, "gps")
    track = read_flysight(inputs["gps"]["file"])
    utc_zero = (inputs.get("imu") or {}).get("utc_at_zero_unix_s")
    if utc_zero is None:
        timeline = Timeline("time since the first fix, s", float(track.time_unix_s[0]))
    else:
        timeline = Timeline(style.FLIGHT_TIME_LABEL, utc_zero + _clock_offset_s(drop) + drop.release_imu_s,
                            _window(drop), _events(drop))
    site = drop.json(RESOLVED).get("site") or {}
    origin = (site["lat_deg"], site["lon_deg"], site["ground_alt_msl_m"]) if "lat_deg" in site else None
    fig = gps_figure(track, f"{drop.name}: GPS data ({Path(track.path).name})", timeline, origin)
    if origin is not None:
        fig.axes[0].set_title("ground track from the site")
    return fig


def inputs_sounding_figure(drop: DropFolder) -> Figure:
    """The fit's sounding against altitude MSL, zoomed on the drop (ground to release) shaded."""
    rec = _inputs(drop, "sounding")["sounding"]
    sounding = read_sounding(rec["file"], launch=int(rec.get("launch", 0)))
    ground = (drop.json(RESOLVED).get("site") or {}).get("ground_alt_msl_m")
    drop_range = None
    if ground is not None:
        top = float(np.nanmax(drop.traj["h_agl_m"]))
        drop_range = (float(ground), float(ground) + top)
    return sounding_figure(sounding, f"{drop.name}: sounding ({Path(rec['file']).name})", drop_range)


#: The input figures of a results folder: (file stem, function of a DropFolder).
INPUT_FIGURES = (("inputs_imu", inputs_imu_figure), ("inputs_gps", inputs_gps_figure),
                 ("inputs_sounding", inputs_sounding_figure))


# ---- any input file -----------------------------------------------------------------------------------


def input_file_figure(path: str | Path) -> Figure:
    """The figure of any supported input file: IMU CSV (the numbers of the file, in the units its
    layout declares: ``time_s,ax,...`` SI, ``ts,...,Gx`` deg/s), FlySight 1 or 2 GPS track, or
    sounding. InputError (located) for a malformed file or a kind without a figure."""
    kind, spec = input_kind(path)
    name = Path(path).name
    if kind == "gps":
        track = read_flysight(path)
        t0 = float(track.time_unix_s[0])
        return gps_figure(track, f"{name}: GPS track", Timeline(f"time since {iso_utc(t0)}, s", t0))
    if kind == "sounding":
        return sounding_figure(read_sounding(path), f"{name}: sounding")
    if kind == "imu":
        log = read_imu_csv(path, spec)
        title = (f"{name}: IMU data as the file holds it (its layout declares accelerometers in "
                 f"{UNIT_LABELS[spec.accel_unit]}, gyros in {UNIT_LABELS[spec.gyro_unit]})")
        return imu_figure(log, title, Timeline("IMU clock, s"), spec.accel_unit, spec.gyro_unit)
    raise InputError(path, f"no figure for a {kind} file (IMU CSV, FlySight track or sounding)", line=1)


def plot_input_file(path: str | Path, out: str | Path, formats: Sequence[str] | None = None) -> list[Path]:
    """Save :func:`input_file_figure` of ``path`` as ``out`` (its suffix picks the format unless
    ``formats`` is given); returns the paths written."""
    out = Path(out)
    if formats is None:
        suffix = out.suffix.lower().lstrip(".")
        formats = (suffix,) if suffix in style.SUPPORTED_FORMATS else style.DEFAULT_FORMATS
    return style.save_figure(input_file_figure(path), out, formats)
