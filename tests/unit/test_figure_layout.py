"""casrecon.report.figure_layout: the fixed layout keeps every label inside the figure and off the
neighbouring panels, the tickers build ticks only inside the view, log labels are plain text; and the
cell labels of figure_style (value outlines) sit on their cells."""

from __future__ import annotations

import numpy as np
import pytest

from casrecon.report import figure_layout as layout
from casrecon.report import figure_style as style


def _fixed_figure(ylabel_lines: int = 1, big: float = 1.0):
    fig, axes = style.new_figure(3, 2, (13, 9.5), fixed=True)
    t = np.linspace(0.3, 40.3, 500)
    for k, ax in enumerate(axes.flat):
        ax.plot(t, -big * 123.456 * np.sin(t + k), color=style.RECONSTRUCTED_COLOR, label="reconstruction")
        ax.set_ylabel("\n".join([f"$C_{k}$ residual, m/s$^2$"] * ylabel_lines))
    layout.log_axis(axes[1, 1].yaxis)
    axes[1, 1].lines[0].set_ydata(1e-6 + np.abs(np.sin(t)))
    for ax in axes[-1]:
        ax.set_xlabel(style.FLIGHT_TIME_LABEL)
    axes[0, 0].set_title("force coefficients")
    axes[0, 1].set_title("moment coefficients")
    style.figure_legend(fig)
    fig.suptitle("a drop: a figure")
    return fig, axes


@pytest.mark.parametrize(("ylabel_lines", "big"), [(1, 1.0), (2, 1e-7), (1, 1e5)])
def test_fixed_layout_keeps_text_inside_the_figure_and_off_the_neighbours(ylabel_lines, big):
    fig, axes = _fixed_figure(ylabel_lines, big)
    engine = fig.get_layout_engine()
    assert isinstance(engine, layout.FixedLayout)
    engine.execute(fig)
    fig.set_layout_engine(None)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    for ax in axes.flat:
        box = ax.get_tightbbox(renderer)
        assert page.x0 <= box.x0 and box.x1 <= page.x1 + 1 and page.y0 <= box.y0 and box.y1 <= page.y1, box
    # the right column's y labels and tick labels stay right of the left column's panels
    for row in axes:
        left_panel, right_ax = row[0].get_window_extent(renderer), row[1]
        assert right_ax.yaxis.get_tightbbox(renderer).x0 > left_panel.x1
    # the rows' x labels and tick labels stay above the next row's panels (and its titles)
    for upper, lower in zip(axes[:-1, 0], axes[1:, 0]):
        assert upper.get_window_extent(renderer).y0 > lower.get_tightbbox(renderer).y1 - 1
    # the legend below every panel, the suptitle above them
    legend = fig.legends[0].get_window_extent(renderer)
    assert legend.y1 < min(ax.xaxis.get_tightbbox(renderer).y0 for ax in axes[-1])
    assert fig.get_suptitle() and max(ax.get_tightbbox(renderer).y1 for ax in axes[0]) < page.y1


def test_save_figure_lays_out_once_and_saves_without_an_engine(tmp_path):
    fig, _ = _fixed_figure()
    paths = style.save_figure(fig, tmp_path / "f", ("png",))
    assert paths == [tmp_path / "f.png"] and paths[0].stat().st_size > 1000
    assert fig.get_layout_engine() is None
    assert 0.0 < fig.subplotpars.left < 0.15 and 0.85 < fig.subplotpars.right < 1.0


def test_tickers_build_ticks_only_inside_the_view():
    fig, axes = style.new_figure(1, 2, (8, 3), fixed=True)
    axes[0, 0].plot([0.3, 40.3], [-0.21, 0.19])
    axes[0, 1].plot([0.3, 40.3], [2.5e-7, 1.1e-2])
    layout.log_axis(axes[0, 1].yaxis)
    for axis in (axes[0, 0].xaxis, axes[0, 0].yaxis, axes[0, 1].yaxis):
        lo, hi = sorted(axis.get_view_interval())
        ticks = axis.get_major_locator()()
        assert len(ticks) >= 3 and np.all((ticks >= lo) & (ticks <= hi)), (ticks, lo, hi)
    assert list(axes[0, 0].xaxis.get_major_locator()()) == [0.0, 10.0, 20.0, 30.0, 40.0]
    assert list(axes[0, 1].yaxis.get_major_locator()()) == pytest.approx([1e-6, 1e-5, 1e-4, 1e-3, 1e-2])
    assert len(axes[0, 1].yaxis.get_minor_locator()()) == 0


def test_short_log_axis_is_ticked_at_1_2_5():
    assert list(layout.LogTicks().tick_values(2.5e-3, 2.7e-2)) == pytest.approx(
        [1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2, 1e-1, 2e-1, 5e-1])


@pytest.mark.parametrize(("value", "text"), [(1e-3, "10\u207b\u00b3"), (2e-5, "2\u00d710\u207b\u2075"),
                                             (0.5, "0.5"), (20.0, "20"), (1e4, "10\u2074"), (0.0, "")])
def test_log_labels_are_plain_text(value, text):
    assert layout.log_label(value) == text


def test_cell_labels_are_centred_on_their_cells():
    fig, axes = style.new_figure(1, 1, (4, 4))
    ax = axes[0, 0]
    ax.imshow(np.eye(2))
    style.cell_labels(ax, [0, 1], [0, 1], ["-0.25", "1.00"], ["white", "black"])
    collections = list(ax.collections)
    assert [tuple(c.get_facecolor()[0][:3]) for c in collections] == [(1.0, 1.0, 1.0), (0.0, 0.0, 0.0)]
    for collection, offset in zip(collections, [[0.0, 0.0], [1.0, 1.0]], strict=True):
        assert collection.get_offsets().tolist() == [offset]
        path = collection.get_paths()[0]
        # centred on the advance width, as a Text with ha="center" (the side bearings: a few tenths of a pt)
        assert np.allclose(path.vertices.min(axis=0) + path.vertices.max(axis=0), 0.0, atol=1.0)
        assert 5.0 < np.ptp(path.vertices[:, 0]) < 25.0  # a few characters of 6 pt text, in pt
