"""casrecon.report.figure_pool.FigurePool: workers forked before the fit draw a drop folder's figures
exactly as draw_figures does (the same files, the same bytes, the same notes)."""

from __future__ import annotations

import json
import time

from figure_files import AERO_FIGURES, DROP_FIGURES

from casrecon.report.figure_pool import FigurePool
from casrecon.report.plots import draw_figures
from tests.unit.test_plots import make_drop_folder, no_render  # noqa: F401  (fixture)


def test_pool_draws_the_same_figures_bit_for_bit(tmp_path):
    ours, theirs = make_drop_folder(tmp_path / "pool"), make_drop_folder(tmp_path / "direct")
    for folder in (ours, theirs):
        (folder / "aero_coefficients.csv").unlink()  # fewer figures to render (and their notes)
    notes_pool: list[str] = []
    with FigurePool() as pool:
        paths = pool.draw(ours, notes_pool)
    notes: list[str] = []
    expected = draw_figures(theirs, notes)
    assert [p.name for p in paths] == [p.name for p in expected]
    assert {p.stem for p in paths} == set(DROP_FIGURES) - set(AERO_FIGURES)
    assert [n.replace(str(ours), str(theirs)) for n in notes_pool] == notes and len(notes) == len(AERO_FIGURES)
    for p, q in zip(paths, expected):
        assert p.parent == ours / "figures"
        assert p.read_bytes() == q.read_bytes(), p.name


def test_pool_reports_a_moved_input_like_draw_figures(tmp_path, no_render):  # noqa: F811
    folder = make_drop_folder(tmp_path / "fit")
    resolved = json.loads((folder / "config" / "resolved.json").read_text())
    resolved["inputs"]["gps"]["file"] = str(tmp_path / "moved.csv")
    (folder / "config" / "resolved.json").write_text(json.dumps(resolved))
    notes: list[str] = []
    with FigurePool() as pool:  # forked after the fixture: the workers skip the rendering too
        paths = pool.draw(folder, notes, formats=("png", "pdf"))
    assert sorted(p.name for p in paths) == sorted(f"{f}.{x}" for f in DROP_FIGURES for x in ("png", "pdf")
                                                   if f != "inputs_gps")
    assert len(notes) == 1 and "moved.csv" in notes[0]


def test_a_failure_in_the_parent_stops_the_workers():
    pool = FigurePool()
    processes = list(pool.pool._processes.values())
    try:
        with pool:
            raise KeyboardInterrupt
    except KeyboardInterrupt:
        pass
    # the executor's own thread may be reaping a worker at the same moment: Popen.poll then sees ECHILD
    # and reports "alive" until that thread records the exit code, so the state is polled, up to 10 s
    deadline = time.monotonic() + 10.0
    for proc in processes:
        proc.join(timeout=10)
        while proc.is_alive() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not proc.is_alive()
