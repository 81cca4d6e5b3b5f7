"""casrecon.output.columns.write_table: the cells of column_cells, one printf per row."""

from __future__ import annotations

import numpy as np

from casrecon.output.columns import column_cells, write_table


def test_table_is_the_column_cells(tmp_path):
    rng = np.random.default_rng(3)
    n = 257
    columns = {"time_imu_s": np.linspace(0, 40, n), "time_unix_s": 1.7e9 + rng.uniform(0, 100, n),
               "lat_deg": rng.uniform(-90, 90, n), "h_agl_m": rng.normal(size=n) * 10.0 ** rng.integers(-12, 12, n),
               "used": rng.integers(0, 2, n), "utc": np.array([f"2024-01-01T00:00:{k:02d}%s" for k in range(n)]),
               "tag_b": np.array([b"a,b"] * n)}
    columns["h_agl_m"][[3, 4, 5, 6]] = [np.nan, np.inf, -np.inf, -0.0]
    for every in (1, 3):
        write_table(tmp_path / "t.csv", columns, every=every)
        cells = [column_cells(name, np.asarray(v)[::every]) for name, v in columns.items()]
        expected = "\n".join([",".join(columns)] + [",".join(r) for r in zip(*cells)]) + "\n"
        assert (tmp_path / "t.csv").read_text() == expected
    write_table(tmp_path / "one.csv", {"x_m": np.array([1.5])})
    assert (tmp_path / "one.csv").read_text() == "x_m\n1.5\n"
