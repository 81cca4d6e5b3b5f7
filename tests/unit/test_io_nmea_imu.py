"""IMU samples in NMEA proprietary sentences (casrecon/io/nmea_imu.py) on a hand-written log,
tests/data/nmea-imu/logger.nmea: $PVER, $GPGGA and $PTH lines among the $PIMU ones, one $PIMU with a
wrong checksum, one without a checksum, a blank line, CRLF endings.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from casrecon.io.errors import InputError
from casrecon.io.imu import STANDARD_GRAVITY, ImuCsvSpec
from casrecon.io.nmea_imu import NmeaImuLayout, read_nmea_imu

LOG = Path(__file__).resolve().parents[1] / "data" / "nmea-imu" / "logger.nmea"
LAYOUT = NmeaImuLayout("PIMU", ("t_ms", "ax", "ay", "az", "wx", "wy", "wz"))
SPEC = ImuCsvSpec(time_column="t_ms", time_unit="ms", accel_unit="g", gyro_unit="deg/s",
                  gyro_limits=((-250.0, 250.0),))


def checksum(body: str) -> str:
    c = 0
    for ch in body:
        c ^= ord(ch)
    return f"${body}*{c:02X}"


def test_reads_the_tagged_sentences_in_si_units():
    log, notes = read_nmea_imu(LOG, LAYOUT, SPEC)
    # lines 2, 4, 7 and 9; line 5 has a wrong checksum, line 7 none
    np.testing.assert_allclose(log.time_s, [1.0, 1.01, 1.03, 1.04])
    np.testing.assert_allclose(log.accel_mps2[0], np.array([0.012, -0.021, 1.002]) * STANDARD_GRAVITY)
    np.testing.assert_allclose(log.gyro_radps[2], np.radians([1.25, 0.25, 3.50]))
    assert log.gyro_saturated[:, 2].tolist() == [False, True, False, False]
    assert not log.accel_saturated.any()
    assert any("3 line(s) other than '$PIMU' skipped" in n for n in notes)
    assert any("1 '$PIMU' sentence(s) with a wrong checksum skipped" in n for n in notes)


def test_axes_and_unused_fields(tmp_path):
    spec = ImuCsvSpec(time_column="t_ms", time_unit="ms", accel_unit="g", gyro_unit="deg/s",
                      axes="y,-x,z")
    log, _ = read_nmea_imu(LOG, LAYOUT, spec)
    np.testing.assert_allclose(log.gyro_radps[0], np.radians([-0.25, -0.50, 12.0]))
    # fields named '-' (here a temperature and a status) are counted but not read
    f = write(tmp_path, [checksum("PIMU,0,25.5,0,0,1,0,0,0,OK"), checksum("PIMU,10,hot,0,0,1,0,0,0,OK")])
    log, notes = read_nmea_imu(f, NmeaImuLayout("PIMU", ("t_ms", "-", *LAYOUT.fields[1:], "-")), SPEC)
    np.testing.assert_allclose(log.time_s, [0.0, 0.01])
    assert notes == ()


def write(tmp_path, lines):
    f = tmp_path / "log.nmea"
    f.write_text("\n".join(lines) + "\n")
    return f


GOOD = [checksum("PIMU,0,0,0,1,0,0,0"), checksum("PIMU,10,0,0,1,0,0,0")]
BREAKS = {
    "too few fields": ([GOOD[0], checksum("PIMU,10,0,0,1,0,0")], 2, None, "6 fields"),
    "text in a field": ([GOOD[0], checksum("PIMU,10,0,abc,1,0,0,0")], 2, "ay", "finite number"),
    "nan in a field": ([GOOD[0], checksum("PIMU,10,0,0,1,nan,0,0")], 2, "wx", "finite number"),
    "blank field": ([checksum("PIMU,0,0,0,1,0,0,")], 1, "wz", "finite number"),
    "time backwards": ([GOOD[1], GOOD[0]], 2, "t_ms", None),
    "duplicated time": ([GOOD[0], GOOD[0]], 2, "t_ms", None),
    "no sentence": ([checksum("GPGGA,1,2,3"), "$PIMU,0,0,0,1,0,0,0*00"], 1, None, "no '$PIMU'"),
}


@pytest.mark.parametrize("case", list(BREAKS))
def test_bad_lines_are_located(tmp_path, case):
    lines, line, field, text = BREAKS[case]
    with pytest.raises(InputError) as e:
        read_nmea_imu(write(tmp_path, lines), LAYOUT, SPEC)
    assert e.value.line == line and e.value.field == field
    if text:
        assert text in str(e.value)


def test_layout_must_name_the_spec_columns_and_be_valid(tmp_path):
    with pytest.raises(InputError, match="names no field t_ms"):
        read_nmea_imu(LOG, NmeaImuLayout("PIMU", ("t", "ax", "ay", "az", "wx", "wy", "wz")), SPEC)
    for tag in ("IMU", "PIMU,", "P", "Pimu"):
        with pytest.raises(ValueError, match="tag"):
            NmeaImuLayout(tag)
    with pytest.raises(ValueError, match="distinct"):
        NmeaImuLayout("PIMU", ("t", "ax", "ax"))
