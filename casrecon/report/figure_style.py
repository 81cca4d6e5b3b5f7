"""Shared look of casrecon's figures: size, resolution, colour code, labels, legends, file formats.

Figures are ``matplotlib.figure.Figure`` objects on an Agg canvas (never pyplot), so nothing is
registered globally and a figure is freed (by the garbage collector) once nothing refers to it. The
per-drop figures use the cheap :class:`casrecon.report.figure_layout.FixedLayout` (``new_figure(...,
fixed=True)``); the others matplotlib's constrained layout.

Colour code (the EES paper's Fig. 12: reconstructed black, nominal database blue, best fit red),
used by every figure for the same meaning: :data:`RECONSTRUCTED_COLOR`, :data:`NOMINAL_COLOR`,
:data:`BEST_FIT_COLOR`, :data:`TRUTH_COLOR`, :data:`MEASUREMENT_COLOR` (sensor data and residuals),
:data:`MASKED_COLOR` (data left out of the fit). Labels use mathtext (``r"$\\bar q$"``,
``r"m/s$^2$"``, :data:`PM3SIGMA`); each figure has one legend (:func:`figure_legend`), not one per
panel. :func:`save_figure` writes PNG and, on request, PDF or SVG.

Every figure can instead be drawn on the caller's own matplotlib axes (``ax=``, :func:`user_axes`):
one Axes per panel, in row-major order; the title and legend then go on those axes' figure.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TypeAlias

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PathCollection
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.path import Path as MplPath
from matplotlib.textpath import TextPath
from matplotlib.transforms import Affine2D

from casrecon.report.figure_layout import FixedLayout, few_ticks, text_width_pt

DPI = 150

#: Colour code of every figure.
RECONSTRUCTED_COLOR = "k"
NOMINAL_COLOR = "tab:blue"
BEST_FIT_COLOR = "tab:red"
TRUTH_COLOR = "tab:green"
MEASUREMENT_COLOR = "tab:orange"
MASKED_COLOR = "tab:purple"
#: Sigma lines and neutral reference lines.
SIGMA_COLOR = "0.25"
#: Opacity of a shaded 3-sigma band.
BAND_ALPHA = 0.25
#: Older names of the colour code (kept for callers outside this package).
RECON_COLOR, GPS_COLOR, SIM_COLOR, MASK_COLOR = RECONSTRUCTED_COLOR, MEASUREMENT_COLOR, BEST_FIT_COLOR, MASKED_COLOR

#: Mathtext pieces of labels.
PM3SIGMA = r"$\pm 3\sigma$"
PM1SIGMA = r"$\pm 1\sigma$"
MPS2 = r"m/s$^2$"
FLIGHT_TIME_LABEL = "flight time since release, s"

#: File formats :func:`save_figure` can write, and the default.
SUPPORTED_FORMATS = ("png", "pdf", "svg")
DEFAULT_FORMATS = ("png",)
#: PNG encoder options: zlib level 1 (the same pixels as the default level 6, files ~12 % larger,
#: encoding ~40 % faster: ~0.5 s of the ~5 s CPU that a drop's 13 figures take).
PNG_OPTIONS = {"compress_level": 1}
#: Lines longer than this are drawn decimated (:func:`decimate`).
MAX_LINE_POINTS = 4000


def parse_formats(text: str) -> tuple[str, ...]:
    """``"png,pdf"`` -> ("png", "pdf"): lower-cased, duplicates dropped, order kept; ValueError
    naming the supported formats for anything else (or an empty list)."""
    formats = tuple(dict.fromkeys(f.strip().lower().lstrip(".") for f in text.split(",") if f.strip()))
    bad = [f for f in formats if f not in SUPPORTED_FORMATS]
    if bad or not formats:
        raise ValueError(f"unsupported figure format {', '.join(bad) or repr(text)}; "
                         f"choose from {', '.join(SUPPORTED_FORMATS)} (comma-separated)")
    return formats


#: What ``ax=`` of a figure function takes: one matplotlib Axes, or a sequence or array of them.
UserAxes: TypeAlias = "Axes | Sequence[Axes] | np.ndarray"


def user_axes(ax: UserAxes, n: int) -> tuple[Figure, np.ndarray]:
    """The figure and the flat object array of the ``n`` axes a caller gave as ``ax=`` (one Axes, or
    a sequence or array of Axes of one figure, one per panel in row-major order).

    Raises
    ------
    ValueError
        Not Axes, not ``n`` of them (the message says how many panels the figure draws), or axes of
        different figures.
    """
    axes = np.empty(1, dtype=object)
    if isinstance(ax, Axes):
        axes[0] = ax
    else:
        axes = np.asarray(list(np.ravel(np.asarray(ax, dtype=object))), dtype=object)
    if axes.size != n or not all(isinstance(a, Axes) for a in axes):
        given = f"{axes.size} item(s) of type {', '.join(sorted({type(a).__name__ for a in axes}))}" \
            if axes.size else "none"
        want = "one matplotlib Axes" if n == 1 else f"{n} matplotlib Axes (e.g. fig.subplots(...)), in row-major order"
        raise ValueError(f"ax: this figure draws {n} panel{'s' if n != 1 else ''}: give {want}; got {given}")
    fig = axes[0].figure
    if any(a.figure is not fig for a in axes):
        raise ValueError("ax: the axes must all belong to one figure")
    return fig, axes


def new_figure(nrows: int, ncols: int, size: tuple[float, float], sharex: bool | str = True, fixed: bool = False,
               ax: UserAxes | None = None):
    """A Figure on an Agg canvas and its axes (2-D array), grid on.

    The layout is matplotlib's constrained layout, or with ``fixed`` the cheaper
    :class:`casrecon.report.figure_layout.FixedLayout` (margins computed once per draw from the text;
    about half the CPU time of a per-drop figure) and at most :data:`casrecon.report.figure_layout.TICK_BINS`
    tick intervals per linear axis (fewer tick artists to build and draw).

    With ``ax`` (:func:`user_axes`: ``nrows * ncols`` axes of the caller's) those axes, reshaped to
    ``(nrows, ncols)``, and their figure are returned instead (size, layout and ``sharex`` are the
    caller's; grid on).
    """
    if ax is not None:
        fig, flat = user_axes(ax, nrows * ncols)
        for a in flat:
            a.grid(True, alpha=0.4)
        return fig, flat.reshape(nrows, ncols)
    fig = Figure(figsize=size, layout=FixedLayout() if fixed else "constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, sharex=sharex, squeeze=False)
    for ax in axes.flat:
        ax.grid(True, alpha=0.4)
        if fixed:
            few_ticks(ax.xaxis)
            few_ticks(ax.yaxis)
    return fig, axes


def save_figure(fig: Figure, path: Path, formats: Sequence[str] = DEFAULT_FORMATS) -> list[Path]:
    """Save ``fig`` as ``path`` with each suffix of ``formats`` (PNG at DPI with :data:`PNG_OPTIONS`; PDF
    and SVG vector, with artists marked ``rasterized`` embedded at DPI) and return the paths written.

    A :class:`~casrecon.report.figure_layout.FixedLayout` figure is laid out here, once, and then saved
    without a layout engine (with one, ``savefig`` runs a whole draw without rendering before the real
    one). The figure is left as it is (``Figure.clear`` costs ~0.05 s a figure; an unreferenced figure
    is freed by the garbage collector). Each file is written beside its name and renamed into place
    when complete: a failed write (disk full, read-only folder) leaves no partial file, and an
    OSError naming the figure's file."""
    engine = fig.get_layout_engine()
    if isinstance(engine, FixedLayout):
        engine.execute(fig)
        fig.set_layout_engine(None)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    for fmt in formats:
        out = path.with_suffix(f".{fmt}")
        tmp = out.with_name(f".{out.name}.tmp-{os.getpid()}")  # never a half-written figure under its name
        try:
            fig.savefig(tmp, dpi=DPI, format=fmt, **({"pil_kwargs": PNG_OPTIONS} if fmt == "png" else {}))
            os.replace(tmp, out)
        except OSError as err:
            tmp.unlink(missing_ok=True)
            raise OSError(err.errno, err.strerror or str(err), str(out)) from err
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        paths.append(out)
    return paths


def figure_legend(fig: Figure, axes: Iterable | None = None, ncol: int | None = None, **kw) -> None:
    """One legend for the whole figure, below the panels: every labelled artist of ``axes``
    (default: all of the figure's), each label once."""
    handles: dict[str, object] = {}
    for ax in (fig.axes if axes is None else axes):
        for h, label in zip(*ax.get_legend_handles_labels()):
            if label and not label.startswith("_"):
                handles.setdefault(label, h)
    if handles:
        n = len(handles)
        ncol = ncol or min(n, 4)
        fontsize = kw.pop("fontsize", 9)
        fig.legend(list(handles.values()), list(handles), loc="outside lower center",
                   ncol=ncol, fontsize=fontsize, frameon=False, **kw)
        engine = fig.get_layout_engine()
        if isinstance(engine, FixedLayout):
            engine.set(legend_rows=-(-n // ncol), legend_fontsize=fontsize)


def decimate(t: np.ndarray, y: np.ndarray, max_points: int = MAX_LINE_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """A line of at most about ``max_points`` points that looks like (t, y) drawn in full: the
    minimum and maximum of each of ``max_points / 2`` consecutive buckets, in time order (keeps
    spikes and saturation plateaus; NaN-free y)."""
    t, y = np.asarray(t), np.asarray(y)
    n = y.size
    if n <= max_points:
        return t, y
    buckets = max(max_points // 2, 1)
    size = int(np.ceil(n / buckets))
    m = n // size * size
    blocks = y[:m].reshape(-1, size)
    base = np.arange(blocks.shape[0]) * size
    pick = np.sort(np.column_stack([base + blocks.argmin(axis=1), base + blocks.argmax(axis=1)]), axis=1).ravel()
    if m < n:
        tail = np.arange(m, n)
        pick = np.r_[pick, tail[[np.argmin(y[m:]), np.argmax(y[m:])]]]
    pick = np.unique(pick)
    return t[pick], y[pick]


def band(ax, t, value, three_sigma, color: str, label: str, band_label: str | None = None) -> None:
    """A line with a shaded +-3-sigma band (same units as value); the band is labelled
    ``band_label`` (default ``"<label> +-3 sigma"``)."""
    ax.fill_between(t, value - three_sigma, value + three_sigma, color=color, alpha=BAND_ALPHA,
                    linewidth=0, label=band_label or f"{label} {PM3SIGMA}")
    ax.plot(t, value, color=color, lw=1.2, label=label)


def sigma_lines(ax, t, sigma, color: str = SIGMA_COLOR) -> None:
    """+-1 sigma (dashed) and +-3 sigma (dotted) lines drawn over the data; sigma a scalar or an
    array over t (same units as the residuals)."""
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), np.shape(t))
    for k, style, label in ((1, "--", PM1SIGMA), (3, ":", PM3SIGMA)):
        kw = dict(color=color, ls=style, lw=1.3, zorder=4)
        ax.plot(t, k * sigma, label=label, **kw)
        ax.plot(t, -k * sigma, **kw)


@functools.lru_cache(maxsize=256)
def _glyph(char: str, size: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Outline (vertices in pt, codes) and advance width (pt) of one character of the default font."""
    outline = TextPath((0.0, 0.0), char, prop=FontProperties(size=size))
    return outline.vertices, outline.codes, text_width_pt(char, size)


def _outline(text: str, size: float) -> MplPath:
    """The outline of a one-line ``text`` (pt, centred on the origin) from cached glyphs (no kerning: for
    numbers, whose digits have equal advances)."""
    vertices, codes, x = [], [], 0.0
    for char in text:
        v, c, advance = _glyph(char, size)
        vertices.append(v + (x, 0.0))
        codes.append(c)
        x += advance
    vertices = np.concatenate(vertices) if vertices else np.zeros((0, 2))
    if vertices.size:
        vertices = vertices - [(x / 2, (vertices[:, 1].min() + vertices[:, 1].max()) / 2)]
    return MplPath(vertices, np.concatenate(codes) if codes else None)


def cell_labels(ax, x, y, texts: Sequence[str], colors: Sequence[str], size: float = 6.0) -> None:
    """Short labels centred on points (x, y) of ``ax`` (data units), such as the values of a matrix's
    cells: drawn as the outlines of the text (one path collection per colour, from glyphs laid out once),
    not one Text artist each (361 Text artists took ~0.4 s to build and draw). ``size`` in pt."""
    groups: dict[str, tuple[list, list]] = {}
    shapes: dict[str, MplPath] = {}
    for xi, yi, text, color in zip(x, y, texts, colors):
        text = text.replace("-", "\u2212")  # the minus sign of tick labels
        if text not in shapes:
            shapes[text] = _outline(text, size)
        paths, offsets = groups.setdefault(color, ([], []))
        paths.append(shapes[text])
        offsets.append((xi, yi))
    points = Affine2D().scale(1.0 / 72.0) + ax.get_figure(root=True).dpi_scale_trans
    for color, (paths, offsets) in groups.items():
        ax.add_collection(PathCollection(paths, offsets=offsets, offset_transform=ax.transData, transform=points,
                                         facecolors=color, edgecolors="none", linewidths=0), autolim=False)


def speed(n, e, d) -> np.ndarray:
    """Norm of the (n, e, d) components, elementwise (same unit)."""
    return np.sqrt(np.asarray(n) ** 2 + np.asarray(e) ** 2 + np.asarray(d) ** 2)
