"""``casrecon inspect FILE --plot OUT`` on shipped and real input files, and the figure-style helpers
(format list, one legend per figure, min-max decimation)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PROBLEMS, REALDATA_DIR
from figure_files import assert_figure_file

from casrecon.cli import main
from casrecon.report import figure_style as style

FILES = {"imu": PROBLEMS / "ees-drop-1" / "data" / "imu.csv",
         "gps-fs1": REALDATA_DIR / "flysight-speed-ssscoring" / "fs1-byron-2019-05-25.CSV",
         "gps-fs2": REALDATA_DIR / "flysight-speed-ssscoring" / "fs2-chicago-2024-09-17" / "TRACK.CSV",
         "sounding-plain": PROBLEMS / "ees-drop-1" / "sounding.csv",
         "sounding-wyoming": REALDATA_DIR / "soundings" / "OUN_72357_2023-05-22_12Z_wyoming.csv",
         "rocket-imu": REALDATA_DIR / "rocket-drogue-descent-hedy" / "imu.csv"}


@pytest.mark.parametrize("kind", list(FILES))
def test_inspect_plot_writes_a_valid_png(kind, tmp_path, capsys):
    out = tmp_path / f"{kind}.png"
    assert main(["inspect", str(FILES[kind]), "--plot", str(out)]) == 0
    assert f"figure -> {out}" in capsys.readouterr().out
    assert_figure_file(out)


def test_inspect_plot_formats(tmp_path, capsys):
    out = tmp_path / "imu.png"
    assert main(["inspect", str(FILES["sounding-plain"]), "--plot", str(out), "--format", "png,pdf"]) == 0
    for path in (out, out.with_suffix(".pdf")):
        assert_figure_file(path)
    assert main(["inspect", str(FILES["sounding-plain"]), "--plot", str(tmp_path / "s.pdf")]) == 0
    assert_figure_file(tmp_path / "s.pdf")


def test_inspect_plot_of_a_kind_without_a_figure_is_one_located_line(tmp_path, capsys):
    sensor = REALDATA_DIR / "flysight-speed-ssscoring" / "fs2-chicago-2024-09-17" / "SENSOR.CSV"
    assert main(["inspect", str(sensor), "--plot", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "SENSOR.CSV" in err and "no figure" in err
    assert not (tmp_path / "x.png").exists()


def test_bad_format_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["inspect", str(FILES["imu"]), "--plot", str(tmp_path / "x.png"), "--format", "png,jpg"])
    assert exc.value.code == 2
    assert "jpg" in capsys.readouterr().err


def test_parse_formats():
    assert style.parse_formats("png, PDF,png,.svg") == ("png", "pdf", "svg")
    for bad in ("", "jpg", "png,eps"):
        with pytest.raises(ValueError, match="png, pdf, svg"):
            style.parse_formats(bad)


def test_one_legend_per_figure_each_label_once():
    fig, axes = style.new_figure(2, 2, (6, 5))
    for ax in axes.flat:
        ax.plot([0, 1], [0, 1], color=style.RECONSTRUCTED_COLOR, label="reconstruction")
    axes[1, 1].plot([0, 1], [1, 0], color=style.BEST_FIT_COLOR, label="best fit")
    axes[0, 0].plot([0, 1], [1, 1], label="_hidden")
    style.figure_legend(fig)
    assert len(fig.legends) == 1 and all(ax.get_legend() is None for ax in fig.axes)
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["reconstruction", "best fit"]


def test_decimate_keeps_every_extreme_of_its_buckets():
    t = np.linspace(0, 10, 100_001)
    y = np.sin(t) + 0.01 * np.random.default_rng(0).normal(size=t.size)
    y[31_234] = 5.0  # a one-sample spike survives
    y[70_000:70_050] = -3.0  # and a clipped plateau
    td, yd = style.decimate(t, y, max_points=2000)
    assert yd.size <= 2002 and np.all(np.diff(td) > 0)
    assert yd.max() == 5.0 and yd.min() == -3.0
    assert set(zip(td, yd)) <= set(zip(t, y))
    short_t, short_y = style.decimate(t[:100], y[:100], max_points=2000)
    assert short_y.size == 100
