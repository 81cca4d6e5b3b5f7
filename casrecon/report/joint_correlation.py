"""Readable correlation figures of a joint fit (49 parameters for the four EES drops).

How they stay readable at 49 parameters:

- **blocked order**: the shared dispersion factors first, then each drop's own parameters
  (``<drop>.<name>``) as one block per drop, in the order of the fit; thick lines separate the
  blocks and the block names (``shared``, ``drop 1`` ...) stand on the top and right edges, so the
  tick labels only need the parameter itself;
- **short mathtext labels** (:func:`casrecon.report.parameter_labels.short_label`:
  ``CA_mult`` -> :math:`C_A` mult, ``ees-drop-2.gyro_bias_x`` -> :math:`b_{\\omega,x}` in block 2);
- **values where they fit**: a cell of at least :data:`DECIMAL_CELL_PT` points gets r with two
  decimals, one of at least :data:`PERCENT_CELL_PT` points gets 100 r as an integer, smaller cells
  get none; only |r| >= :data:`MIN_PRINTED` is printed (the rest is the blank, white colour);
- **a condensed view** (:func:`shared_correlation_figure`): the shared factors against each other
  and against every drop's own parameters, with values, which is where a joint fit's
  correlations that matter live (a drop's own block looks like its single-drop fit).
"""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from casrecon.report import figure_style as style
from casrecon.report.parameter_labels import short_label, split_name
from casrecon.report.results_folder import MissingInput

#: Smallest |r| printed in a cell, -.
MIN_PRINTED = 0.1
#: Cell size (points) from which r is printed with two decimals ...
DECIMAL_CELL_PT = 26.0
#: ... and from which 100 r is printed as an integer; below it no values are printed.
PERCENT_CELL_PT = 12.0
#: Colour map and the |r| above which a printed value is white.
CMAP, WHITE_ABOVE = "RdBu_r", 0.6


def correlation_matrix(parameters: dict) -> tuple[list[str], np.ndarray]:
    """Names and matrix of ``parameters.json``'s ``correlation`` (MissingInput if absent)."""
    corr = parameters.get("correlation")
    if not corr or "names" not in corr or "matrix" not in corr:
        raise MissingInput("parameters.json has no correlation {names, matrix}")
    return list(corr["names"]), np.asarray(corr["matrix"], dtype=float)


def blocks(names: list[str]) -> list[tuple[str, list[int]]]:
    """(block name, indices) in figure order: "shared" (undotted names) first, then each drop's
    ``<drop>.<name>`` parameters, drops in order of first appearance; empty blocks left out."""
    order: dict[str, list[int]] = {"": []}
    for i, name in enumerate(names):
        order.setdefault(split_name(name)[0], []).append(i)
    return [(drop or "shared", idx) for drop, idx in order.items() if idx]


def block_title(name: str, k: int) -> str:
    """Label of block ``k`` (0 = shared): ``shared`` or ``drop k: <name>``."""
    return name if name == "shared" else f"drop {k}: {name}"


def _figure(size: tuple[float, float], ax: style.UserAxes | None = None, **grid) -> tuple[Figure, np.ndarray]:
    if ax is not None:
        return style.user_axes(ax, grid.get("ncols", 1))
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, np.atleast_1d(fig.subplots(1, grid.pop("ncols", 1), squeeze=False, gridspec_kw=grid or None)[0])


def _values(ax, mat: np.ndarray, cell_pt: float, skip_diagonal: bool) -> str:
    """Print the values of ``mat`` in its cells as the cell size allows; returns what was printed."""
    if cell_pt >= DECIMAL_CELL_PT:
        fmt, what, size = "{:.2f}", "r", min(8.0, 0.3 * cell_pt)
    elif cell_pt >= PERCENT_CELL_PT:
        fmt, what, size = "{:.0f}", "100 r", min(8.0, 0.42 * cell_pt)
    else:
        return "no values (cells too small)"
    scale = 100.0 if what == "100 r" else 1.0
    for i, j in zip(*np.nonzero(np.abs(mat) >= MIN_PRINTED)):
        if skip_diagonal and i == j:
            continue
        ax.text(j, i, fmt.format(scale * mat[i, j]), ha="center", va="center", fontsize=size,
                color="white" if abs(mat[i, j]) > WHITE_ABOVE else "black")
    return f"values: {what} where |r| $\\geq$ {MIN_PRINTED:g}"


def _block_edges(ax, sizes_rows: list[int], sizes_cols: list[int]) -> None:
    for k in np.cumsum(sizes_rows)[:-1]:
        ax.axhline(k - 0.5, color="k", lw=1.4)
    for k in np.cumsum(sizes_cols)[:-1]:
        ax.axvline(k - 0.5, color="k", lw=1.4)


def _block_names(ax, titles: list[str], sizes: list[int], axis: str) -> None:
    """Block titles centred on their blocks along the top (``axis="x"``) or right (``"y"``) edge."""
    centres = np.cumsum(sizes) - np.asarray(sizes) / 2.0 - 0.5
    if axis == "x":
        sec = ax.secondary_xaxis("top")
        sec.set_xticks(centres, titles, fontsize=9, fontweight="bold")
    else:
        sec = ax.secondary_yaxis("right")
        sec.set_yticks(centres, titles, fontsize=9, fontweight="bold", rotation=90, va="center")
    sec.tick_params(length=0)


def _heatmap(ax, mat: np.ndarray, rows: list[str], cols: list[str]):
    img = ax.imshow(mat, cmap=CMAP, vmin=-1.0, vmax=1.0, interpolation="nearest", aspect="equal")
    ax.grid(False)
    return img


def _tick_labels(ax, rows: list[str], cols: list[str], font: float) -> None:
    ax.set_xticks(range(len(cols)), [short_label(n) for n in cols], rotation=90, fontsize=font)
    ax.set_yticks(range(len(rows)), [short_label(n) for n in rows], fontsize=font)


def joint_correlation_figure(parameters: dict, title: str, *, ax: style.UserAxes | None = None) -> Figure:
    """The whole correlation matrix of a joint fit's ``parameters.json``, blocked (shared factors,
    then each drop's own parameters), short labels, values where the cells are large enough."""
    names, mat = correlation_matrix(parameters)
    parts = blocks(names)
    order = [i for _, idx in parts for i in idx]
    names, mat = [names[i] for i in order], mat[np.ix_(order, order)]
    n = len(names)
    side = float(np.clip(3.5 + 0.26 * n, 6.0, 18.0))
    fig, (ax,) = _figure((side + 1.0, side + 0.5), ax)
    img = _heatmap(ax, mat, names, names)
    cell_pt = 0.78 * side * 72.0 / max(n, 1)
    _tick_labels(ax, names, names, float(np.clip(0.62 * cell_pt, 6.0, 11.0)))
    sizes = [len(idx) for _, idx in parts]
    titles = [block_title(b, k) for k, (b, _) in enumerate(parts)]
    _block_edges(ax, sizes, sizes)
    if len(parts) > 1:
        _block_names(ax, titles, sizes, "x")
        _block_names(ax, titles, sizes, "y")
    printed = _values(ax, mat, cell_pt, skip_diagonal=True)
    fig.colorbar(img, ax=ax, location="bottom", shrink=0.5, aspect=40, fraction=0.03, pad=0.01,
                 label="correlation coefficient $r$, -")
    fig.suptitle(f"{title}: parameter correlations ({n} parameters; {printed})")
    return fig


def shared_correlation_figure(parameters: dict, title: str, *, ax: style.UserAxes | None = None) -> Figure:
    """Condensed view of a joint fit's correlations: the shared factors against each other (top
    left) and against each drop's own parameters (one panel per drop, two per row), with values;
    MissingInput when the fit has no shared or no per-drop parameters. With ``ax``: one Axes of the
    caller's for the shared block, then one per drop."""
    names, mat = correlation_matrix(parameters)
    parts = blocks(names)
    if len(parts) < 2 or parts[0][0] != "shared":
        raise MissingInput("the joint fit has no shared and per-drop parameters to set side by side")
    shared, drops = parts[0][1], parts[1:]
    n_rows = -(-len(drops) // 2)
    mosaic = [["shared" if r == 0 else "."] + [f"d{2 * r + c}" for c in range(2)] for r in range(n_rows)]
    mosaic = [[m if m[0] != "d" or int(m[1:]) < len(drops) else "." for m in row] for row in mosaic]
    n_local = max(len(idx) for _, idx in drops)
    n_cols = len(shared) + 2 * n_local
    width = float(np.clip(2.5 + 0.45 * n_cols, 8.0, 18.0))
    height = float(np.clip(1.2 + n_rows * (1.3 + 0.36 * len(shared)), 4.5, 16.0))
    if ax is not None:
        fig, given = style.user_axes(ax, 1 + len(drops))
        axes = {"shared": given[0], **{f"d{k}": a for k, a in enumerate(given[1:])}}
    else:
        fig = Figure(figsize=(width, height), layout="constrained")
        FigureCanvasAgg(fig)
        axes = fig.subplot_mosaic(mosaic, width_ratios=[len(shared), n_local, n_local])
    cell_pt = 0.8 * width * 72.0 / n_cols
    font = float(np.clip(0.5 * cell_pt, 7.0, 10.0))
    rows = [names[i] for i in shared]
    img = _heatmap(axes["shared"], mat[np.ix_(shared, shared)], rows, rows)
    _tick_labels(axes["shared"], rows, rows, font)
    printed = _values(axes["shared"], mat[np.ix_(shared, shared)], cell_pt, skip_diagonal=True)
    axes["shared"].set_title("shared factors with each other", fontsize=10)
    for k, (drop, idx) in enumerate(drops):
        ax = axes[f"d{k}"]
        cols = [names[i] for i in idx]
        _heatmap(ax, mat[np.ix_(shared, idx)], rows, cols)
        _tick_labels(ax, rows, cols, font)
        _values(ax, mat[np.ix_(shared, idx)], cell_pt, skip_diagonal=False)
        ax.set_title(f"shared factors with {block_title(drop, k + 1)}", fontsize=10)
    fig.colorbar(img, ax=list(axes.values()), location="right", shrink=0.7, label="correlation coefficient $r$, -")
    fig.suptitle(f"{title}: correlations of the shared factors ({printed})")
    return fig
