"""A cheap layout for casrecon's per-drop figures: margins computed once per draw from the text they hold.

Constrained layout measures the drawn extent of every tick label, axis label and title in two passes,
and ``savefig`` of a figure with any layout engine draws it once without rendering before the real
draw: on the per-drop figures that was about half of their CPU time. :class:`FixedLayout` instead
places the grid of panels with ``Figure.subplots_adjust`` from what the text will need, in inches
(:func:`casrecon.report.figure_style.save_figure` runs it once and saves without an engine):

- left of each column: the widest y tick label the axis formatter will write (measured with the font's
  metrics, no rendering), the tick and its pads, and the y label (line count times its font size);
- under each row: the x tick labels (if shown) and the x label; over each row: the title, and the
  offset text (``1e-5``) of a y axis;
- top: the suptitle; bottom: the figure legend below the panels (:meth:`FixedLayout.set` ``legend_rows``,
  set by :func:`casrecon.report.figure_style.figure_legend`).

It assumes what :func:`casrecon.report.figure_style.new_figure` builds: one grid of panels (any axes
outside a grid keeps its place), tick labels left and below, a suptitle at the top and the legend at the
lower centre. The tickers here keep the number of tick objects small (each costs a few Line2D and Text
artists): :func:`few_ticks` on linear axes and :func:`log_axis` (decades, or 1-2-5 per decade on a
short axis, no minor ticks, labels in plain text such as ``10⁻³`` or ``2×10⁻³`` without mathtext).
"""

from __future__ import annotations

import functools
import math

import matplotlib as mpl
import numpy as np
from matplotlib.font_manager import FontProperties
from matplotlib.layout_engine import LayoutEngine
from matplotlib.textpath import text_to_path
from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullLocator

#: Major tick intervals of a linear axis (at most; matplotlib's default goes up to 9 on a wide panel).
TICK_BINS = 6
#: A log axis spanning fewer decades than this is ticked at 1, 2 and 5 times each decade.
FEW_DECADES = 3.0
#: Space kept free at each edge of the figure, inches.
EDGE_IN = 0.06
#: Space kept free between neighbouring panels' text, inches.
GAP_IN = 0.12
#: Line height of text, in units of its font size (mathtext with sub- or superscripts: :data:`MATH_LINE`).
LINE = 1.2
MATH_LINE = 1.45
SUPERSCRIPTS = str.maketrans("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079")


def in_view(axis, ticks) -> np.ndarray:
    """The ticks (data units) inside the axis's view interval: matplotlib builds a tick object (three
    lines and two texts) for every location its locator returns, drawn or not."""
    lo, hi = sorted(axis.get_view_interval())
    ticks = np.asarray(ticks, dtype=float)
    tol = 1e-9 * max(abs(lo), abs(hi), 1e-300)
    return ticks[(ticks >= lo - tol) & (ticks <= hi + tol)]


class FewTicks(MaxNLocator):
    """At most ``nbins`` major tick intervals on a linear axis (steps 1, 2, 2.5, 5 times a power of ten),
    only the ticks inside the view."""

    def __init__(self, nbins: int = TICK_BINS):
        super().__init__(nbins=nbins, steps=[1, 2, 2.5, 5, 10])

    def __call__(self):
        """The tick locations of the axis's view (data units)."""
        return in_view(self.axis, super().__call__())


def few_ticks(axis, bins: int = TICK_BINS) -> None:
    """:class:`FewTicks` on a linear axis."""
    axis.set_major_locator(FewTicks(bins))


class LogTicks(LogLocator):
    """Major ticks of a log axis inside its view: each decade (every n-th when there are more than
    :data:`TICK_BINS`), or 1, 2 and 5 times each decade when the axis spans fewer than
    :data:`FEW_DECADES` decades."""

    def __call__(self):
        """The tick locations of the axis's view (data units)."""
        return in_view(self.axis, super().__call__())

    def tick_values(self, vmin, vmax):
        """Tick values (data units) of the interval; matplotlib drops those outside the view."""
        lo, hi = sorted((float(vmin), float(vmax)))
        if not (lo > 0 and np.isfinite(hi)):
            return super().tick_values(vmin, vmax)
        first, last = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
        if math.log10(hi / lo) < FEW_DECADES:
            return np.array([m * 10.0 ** e for e in range(first, last + 1) for m in (1.0, 2.0, 5.0)])
        step = max(1, math.ceil((last - first) / TICK_BINS))
        return 10.0 ** np.arange(first - first % step, last + step, step, dtype=float)


def log_label(value: float, _pos=None) -> str:
    """``10⁻³``, ``2×10⁻³`` (plain text, no mathtext); values from 0.1 to 1000 as plain numbers."""
    if not value > 0:
        return ""
    exponent = math.floor(math.log10(value) + 1e-9)
    mantissa = round(value / 10.0 ** exponent, 6)
    if -1 <= exponent <= 3:
        return f"{value:g}"
    power = "10" + str(exponent).translate(SUPERSCRIPTS)
    return power if mantissa == 1 else f"{mantissa:g}\u00d7{power}"


def log_axis(axis, plain: bool = False) -> None:
    """Log scale on ``axis`` with :class:`LogTicks`, no minor ticks, labels by :func:`log_label` (``plain``:
    every label a plain number, ``0.2``, ``50``)."""
    axis.axes.set_xscale("log") if axis is axis.axes.xaxis else axis.axes.set_yscale("log")
    axis.set_major_locator(LogTicks())
    axis.set_minor_locator(NullLocator())
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}") if plain else FuncFormatter(log_label))


@functools.lru_cache(maxsize=4096)
def text_width_pt(text: str, size: float) -> float:
    """Width (pt) of one line of plain text in the default font at ``size`` pt."""
    if "$" in text:  # mathtext: a generous estimate rather than a parse
        return 0.62 * size * len(text.replace("$", "").replace("\\", ""))
    return text_to_path.get_text_width_height_descent(text, FontProperties(size=size), ismath=False)[0]


def _height_pt(text) -> float:
    """Height (pt) of a Text artist's lines (0 if it is empty or hidden)."""
    content = text.get_text()
    if not content or not text.get_visible():
        return 0.0
    line = MATH_LINE if "$" in content else LINE
    return (content.count("\n") + 1) * line * text.get_fontsize()


def _tick_labels(axis) -> list[str]:
    """The major tick labels the axis will draw (inside its view interval)."""
    locs = in_view(axis, axis.get_majorticklocs())
    return [s for s in axis.get_major_formatter().format_ticks(locs) if s]


def _tick_size(axis, name: str) -> float:
    """Tick length plus label pad (pt) of an x or y axis from the rcParams."""
    return mpl.rcParams[f"{name}tick.major.size"] + mpl.rcParams[f"{name}tick.major.pad"]


def _shown(axis, side: str) -> bool:
    return bool(axis.get_tick_params().get(f"label{side}", mpl.rcParams[f"{axis.axis_name}tick.label{side}"]))


def y_width_in(ax) -> float:
    """Space (in) left of a panel: its y tick labels, tick and y label."""
    yaxis, width = ax.yaxis, 0.0
    if _shown(yaxis, "left"):
        size = FontProperties(size=mpl.rcParams["ytick.labelsize"]).get_size_in_points()
        labels = _tick_labels(yaxis)
        width = max((text_width_pt(s, size) for s in labels), default=0.0) + _tick_size(yaxis, "y")
    if yaxis.label.get_text():
        width += yaxis.labelpad + _height_pt(yaxis.label)
    return width / 72.0


def x_height_in(ax) -> float:
    """Space (in) under a panel: its x tick labels (if shown) and x label."""
    xaxis, height = ax.xaxis, 0.0
    if _shown(xaxis, "bottom"):
        size = FontProperties(size=mpl.rcParams["xtick.labelsize"]).get_size_in_points()
        height = LINE * size + _tick_size(xaxis, "x")
    if xaxis.label.get_text():
        height += xaxis.labelpad + _height_pt(xaxis.label)
    return height / 72.0


def top_height_in(ax) -> float:
    """Space (in) over a panel: its title (and its pad), or a y axis offset text (``1e-5``)."""
    title = _height_pt(ax.title)
    title += mpl.rcParams["axes.titlepad"] if title else 0.0
    offset = 0.0
    if _shown(ax.yaxis, "left"):
        _tick_labels(ax.yaxis)  # sets the formatter's offset
        formatter = ax.yaxis.get_major_formatter()
        if hasattr(formatter, "get_offset") and formatter.get_offset():
            offset = LINE * ax.yaxis.offsetText.get_fontsize() + 2.0
    return max(title, offset) / 72.0


class FixedLayout(LayoutEngine):
    """Layout engine: the figure's grid of panels placed once per draw with margins computed from its text.

    Parameters
    ----------
    right : float
        Space right of the last column, in (tick labels overhanging the panel edge).
    legend_rows : int
        Rows of the figure legend below the panels (0: none).
    legend_fontsize : float
        Font size of the legend, pt.
    """

    _adjust_compatible = True
    _colorbar_gridspec = True

    def __init__(self, right: float = 0.25, legend_rows: int = 0, legend_fontsize: float = 9.0, **kwargs):
        super().__init__(**kwargs)
        self._params = {"right": right, "legend_rows": legend_rows, "legend_fontsize": legend_fontsize}

    def set(self, **kwargs) -> None:
        """Set ``right`` (in), ``legend_rows`` or ``legend_fontsize`` (pt)."""
        unknown = set(kwargs) - set(self._params)
        if unknown:
            raise TypeError(f"FixedLayout has no parameter {', '.join(sorted(unknown))}")
        self._params.update(kwargs)

    def legend_height_in(self) -> float:
        """Height (in) of the legend below the panels, with its pads."""
        rows, size = self._params["legend_rows"], self._params["legend_fontsize"]
        if not rows:
            return 0.0
        spacing, pad = mpl.rcParams["legend.labelspacing"], mpl.rcParams["legend.borderpad"]
        return size * (1.45 * rows + spacing * (rows - 1) + 2 * pad + mpl.rcParams["legend.borderaxespad"]) / 72.0

    def execute(self, fig) -> None:
        """Place the panels of ``fig`` (``Figure.subplots_adjust``)."""
        panels = [ax for ax in fig.axes if ax.get_subplotspec() is not None and ax.get_visible()]
        if not panels:
            return
        nrows, ncols = panels[0].get_subplotspec().get_gridspec().get_geometry()
        left, below, above = [0.0] * ncols, [0.0] * nrows, [0.0] * nrows
        for ax in panels:
            spec = ax.get_subplotspec()
            if not ax.axison:
                continue
            left[spec.colspan.start] = max(left[spec.colspan.start], y_width_in(ax))
            below[spec.rowspan.stop - 1] = max(below[spec.rowspan.stop - 1], x_height_in(ax))
            above[spec.rowspan.start] = max(above[spec.rowspan.start], top_height_in(ax))
        width, height = fig.get_size_inches()
        suptitle = fig.get_suptitle()
        title_in = 0.0
        if suptitle:
            size = FontProperties(size=mpl.rcParams["figure.titlesize"]).get_size_in_points()
            title_in = 0.02 * height + (suptitle.count("\n") + 1) * LINE * size / 72.0 + 0.04
        top_in = EDGE_IN + title_in + above[0]
        bottom_in = EDGE_IN + below[-1] + (self.legend_height_in() + 0.05 if self._params["legend_rows"] else 0.0)
        left_in, right_in = EDGE_IN + left[0], self._params["right"]
        wspace_in = max((GAP_IN + left[c] for c in range(1, ncols)), default=0.0)
        hspace_in = max((GAP_IN + below[r - 1] + above[r] for r in range(1, nrows)), default=0.0)
        panel_w = (width - left_in - right_in - (ncols - 1) * wspace_in) / ncols
        panel_h = (height - top_in - bottom_in - (nrows - 1) * hspace_in) / nrows
        if panel_w <= 0 or panel_h <= 0:
            return  # text larger than the figure: leave matplotlib's default placement
        fig.subplots_adjust(left=left_in / width, right=1 - right_in / width, bottom=bottom_in / height,
                            top=1 - top_in / height, wspace=wspace_in / panel_w, hspace=hspace_in / panel_h)
