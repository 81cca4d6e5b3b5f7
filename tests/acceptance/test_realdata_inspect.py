"""``casrecon inspect`` on the real data in tests/data/realdata (copies of ../shared/realdata) (read only), and on
malformed copies of it: exit status 2 with exactly one located stderr line, never a traceback."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REALDATA_DIR

from casrecon.cli import main

REAL = REALDATA_DIR
SOUNDINGS = sorted(p for p in (REAL / "soundings").iterdir() if p.name != "LICENSE")
FS1 = REAL / "flysight-speed-ssscoring/fs1-byron-2019-05-25.CSV"
FS2 = REAL / "flysight-speed-ssscoring/fs2-chicago-2024-09-17/TRACK.CSV"
SKYDERBY = REAL / "flysight-speed-skyderby/speed_skydiving_411.csv"
TRACKS = [FS1, FS2, SKYDERBY]

pytestmark = pytest.mark.skipif(not REAL.is_dir(), reason="real data not present")


def test_all_soundings_found():
    assert len(SOUNDINGS) == 5


@pytest.mark.parametrize("path", SOUNDINGS + TRACKS, ids=lambda p: p.name)
def test_inspect_reads_real_file(path, capsys):
    assert main(["inspect", str(path)]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert "rows:" in out or "levels:" in out
    kind = "sounding" if path in SOUNDINGS else "FlySight"
    assert kind.lower() in out.lower()


def test_console_script_subprocess():
    exe = shutil.which("casrecon") or str(Path(sys.executable).with_name("casrecon"))
    res = subprocess.run([exe, "inspect", str(FS1)], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0 and res.stderr == ""
    assert "FlySight 1 GPS track" in res.stdout and "rows: 5729" in res.stdout
    bad = subprocess.run([exe, "inspect", "/nonexistent/file.csv"], capture_output=True, text=True,
                         timeout=60)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1


# FlySight 1: line 1 header, line 2 units, data from line 3. Each edit of a copy, and the line
# the error must name.
def fs1_edits(lines: list[str]) -> dict[str, tuple[list[str], int]]:
    row = 10  # 0-based index of the 11th line, a data row
    cells = lines[row].split(",")

    def with_cell(i: int, value: str) -> list[str]:
        c = list(cells)
        c[i] = value
        return [*lines[:row], ",".join(c), *lines[row + 1:]]

    prev_time = lines[row - 1].split(",")[0]
    return {
        "truncated row": ([*lines[:row], ",".join(cells[:5]), *lines[row + 1:]], row + 1),
        "unparseable number": (with_cell(3, "4o2.5"), row + 1),
        "NaN": (with_cell(1, "NaN"), row + 1),
        "time going backwards": (with_cell(0, _earlier(prev_time)), row + 1),
        "missing column": ([lines[0].replace(",velD,", ",velQ,"), *lines[1:]], 1),
        "unknown unit": ([lines[0], lines[1].replace("(m/s),(m/s),(m/s)", "(m/s),(ft/s),(m/s)", 1),
                          *lines[2:]], 2),
    }


def _earlier(iso: str) -> str:
    # 2019-05-25T20:21:20.40Z -> 2019-05-25T20:21:10.40Z (ten seconds earlier)
    m = re.match(r"(.*T\d\d:\d\d:)(\d\d)(\..*)", iso)
    return f"{m.group(1)}{int(m.group(2)) - 10:02d}{m.group(3)}"


@pytest.mark.parametrize("case", ["truncated row", "unparseable number", "NaN", "time going backwards",
                                  "missing column", "unknown unit"])
def test_malformed_fs1_copy(tmp_path, capsys, case):
    lines = FS1.read_text().splitlines()
    edited, line = fs1_edits(lines)[case]
    assert edited != lines
    bad = tmp_path / "bad.CSV"
    bad.write_text("\n".join(edited) + "\n")
    assert main(["inspect", str(bad)]) == 2
    out, err = capsys.readouterr()
    err_lines = err.strip().splitlines()
    assert len(err_lines) == 1, err
    assert err_lines[0].startswith(f"casrecon: {bad}:{line}: "), err_lines[0]
    assert "Traceback" not in err and out == ""


@pytest.mark.parametrize("case", ["truncated row", "unparseable number", "NaN", "altitude going backwards",
                                  "missing column"])
def test_malformed_sounding_copy(tmp_path, capsys, case):
    src = REAL / "soundings/OUN_72357_2023-05-22_12Z_wyoming.csv"
    lines = src.read_text().splitlines()
    row = 12
    cells = lines[row].split(",")
    header = lines[0]
    # columns: time, longitude, latitude, pressure_hPa (index 3, used), geopotential height_m, ...
    if case == "truncated row":
        lines[row] = ",".join(cells[:3])
    elif case == "unparseable number":
        cells[3] = "9x5.0"
        lines[row] = ",".join(cells)
    elif case == "NaN":
        cells[3] = "nan"
        lines[row] = ",".join(cells)
    elif case == "altitude going backwards":
        lines[row], lines[row + 1] = lines[row + 1], lines[row]
    else:
        assert header.split(",")[3] == "pressure_hPa"
        lines[0] = header.replace("pressure_hPa", "pressure_xx", 1)
        row = 0
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    assert main(["inspect", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]
    # the line named: the edited row (1-based row + 1), or the second of two swapped rows
    ok = {row + 1, row + 2} if case == "altitude going backwards" else {row + 1}
    m = re.match(rf"casrecon: {re.escape(str(bad))}:(\d+): ", err[0])
    assert m and int(m.group(1)) in ok, err[0]
