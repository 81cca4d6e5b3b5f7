"""NMEA 0183 logs (GGA, RMC, VTG, GSA): values, accuracies from DOP, checksums, dates, missing
components, and one located line (exit 2) for every broken file."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

from casrecon.cli import main
from casrecon.io.errors import InputError
from casrecon.io.gps_files import gps_file_kind, read_gps_track
from casrecon.io.input_kind import input_kind
from casrecon.io.nmea import FALLBACK_HDOP, SPEED_SIGMA_MPS, UERE_M, VDOP_PER_HDOP, is_nmea, read_nmea


def sentence(body: str) -> str:
    """``$body*hh`` with its checksum."""
    x = 0
    for ch in body:
        x ^= ord(ch)
    return f"${body}*{x:02X}"


# the NMEA standard's worked examples (checksums as published)
RMC = "$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A"
GGA = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47"
GSA = "$GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,2.1*39"
VTG = "$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48"
T0 = dt.datetime(1994, 3, 23, 12, 35, 19, tzinfo=dt.UTC).timestamp()


def epoch(t: str, lat: str = "4807.038", talker: str = "GP", speed: str = "022.4", course: str = "084.4",
          date: str = "230394", alt: str = "545.4") -> list[str]:
    return [sentence(f"{talker}RMC,{t},A,{lat},N,01131.000,E,{speed},{course},{date},003.1,W"),
            sentence(f"{talker}GGA,{t},{lat},N,01131.000,E,1,08,0.9,{alt},M,46.9,M,,")]


def write(tmp_path, lines: list[str], name: str = "log.nmea"):
    f = tmp_path / name
    f.write_text("\n".join(lines) + "\n")
    return f


def test_published_examples(tmp_path):
    track = read_nmea(write(tmp_path, [RMC, GGA, GSA, VTG]))
    assert track.format == "nmea" and track.n == 1
    assert track.time_unix_s[0] == T0
    assert track.lat_deg[0] == pytest.approx(48 + 7.038 / 60) and track.lon_deg[0] == pytest.approx(11 + 31 / 60)
    assert track.h_msl_m[0] == 545.4                       # GGA altitude is MSL (geoid separation apart)
    speed = 22.4 * 1852 / 3600                             # RMC speed and course win over VTG
    assert track.vel_n_mps[0] == pytest.approx(speed * math.cos(math.radians(84.4)))
    assert track.vel_e_mps[0] == pytest.approx(speed * math.sin(math.radians(84.4)))
    assert np.isnan(track.vel_d_mps[0])                    # NMEA has no vertical velocity
    # accuracies: GGA HDOP 0.9 (radial, split over north and east), GSA VDOP 2.1, times the UERE
    assert track.h_acc_m[0] == pytest.approx(0.9 * UERE_M / math.sqrt(2))
    assert track.v_acc_m[0] == pytest.approx(2.1 * UERE_M)
    assert track.s_acc_mps[0] == SPEED_SIGMA_MPS
    assert track.num_sv[0] == 8 and track.gps_fix[0] == 3


def test_vtg_velocity_and_dop_fallbacks(tmp_path):
    gga = sentence("GNGGA,123519,4807.038,N,01131.000,E,1,08,,545.4,M,46.9,M,,")   # no HDOP
    gsa = sentence("GNGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.5,")                      # no VDOP: from PDOP
    vtg = sentence("GNVTG,90.0,T,,M,,N,36.0,K,A")                                   # km/h only
    track = read_nmea(write(tmp_path, [gga, gsa, vtg]), date=dt.date(1994, 3, 23))
    assert track.vel_n_mps[0] == pytest.approx(0.0, abs=1e-12) and track.vel_e_mps[0] == pytest.approx(10.0)
    assert track.h_acc_m[0] == pytest.approx(1.5 * UERE_M / math.sqrt(2))           # GSA HDOP
    assert track.v_acc_m[0] == pytest.approx(math.sqrt(2.5**2 - 1.5**2) * UERE_M)
    no_dop = read_nmea(write(tmp_path, [sentence("GPGGA,123519,4807.038,N,01131.000,E,1,08,,545.4,M,,M,,")],
                             "g.nmea"), date="1994-03-23")
    assert no_dop.h_acc_m[0] == pytest.approx(FALLBACK_HDOP * UERE_M / math.sqrt(2))
    assert no_dop.v_acc_m[0] == pytest.approx(VDOP_PER_HDOP * FALLBACK_HDOP * UERE_M)
    assert np.isnan(no_dop.vel_n_mps[0]) and np.isnan(no_dop.s_acc_mps[0])        # no speed sentence
    assert any("without any DOP" in n for n in no_dop.notes)


def test_rmc_only_has_no_altitude(tmp_path):
    track = read_nmea(write(tmp_path, [RMC]))
    assert np.isnan(track.h_msl_m[0]) and np.isnan(track.v_acc_m[0]) and track.gps_fix[0] == 3


def test_bad_checksum_lines_skipped_and_counted(tmp_path):
    lines = epoch("120000.00") + epoch("120000.20") + epoch("120000.40")
    lines[2] = lines[2][:-2] + ("00" if lines[2][-2:] != "00" else "01")   # corrupt one RMC
    lines.insert(1, "$GPGGA,120000.00,4807.038,N,01131.000,E,1,08,0.9,545.4,M")   # cut mid-line
    lines.append(sentence("GPGSV,3,1,11,03,03,111,00"))                             # another sentence
    lines.append(sentence("XXGGA,120000.60,4807.038,N,01131.000,E,1,08,0.9,545.4,M,,M,,"))  # unknown talker
    track = read_nmea(write(tmp_path, lines))
    assert track.n == 3                                 # the corrupt RMC's epoch keeps its GGA
    assert np.diff(track.time_unix_s) == pytest.approx([0.2, 0.2])
    note = next(n for n in track.notes if "skipped" in n)
    assert "bad checksum 1" in note and "no checksum 1" in note and "other sentences 2" in note


def test_talkers_and_midnight(tmp_path):
    lines = epoch("235959.80", talker="GN", date="311299") + epoch("000000.00", talker="GN", date="010100")
    track = read_nmea(write(tmp_path, lines))
    assert track.time_unix_s[1] - track.time_unix_s[0] == pytest.approx(0.2)
    # GGA only, across midnight, the date given for the first fix
    gga = [e for e in lines if "GGA" in e]
    track = read_nmea(write(tmp_path, gga, "g.nmea"), date="1999-12-31")
    assert track.time_unix_s[1] == pytest.approx(dt.datetime(2000, 1, 1, tzinfo=dt.UTC).timestamp())


def test_no_fix_epochs_marked(tmp_path):
    void = sentence("GPRMC,120000.40,V,,,,,,,230394,,,N")
    gga0 = sentence("GPGGA,120000.40,,,,,0,00,99.9,,M,,M,,")
    track = read_nmea(write(tmp_path, epoch("120000.00") + [void, gga0]))
    assert track.gps_fix.tolist() == [3, 0]


def test_read_gps_track_and_input_kind(tmp_path):
    f = write(tmp_path, [RMC, GGA])
    assert read_gps_track(f).format == "nmea"
    assert input_kind(f) == ("nmea", None)


@pytest.mark.parametrize("lines, line, field, what", [
    (["$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*00"], None, None, "no usable NMEA"),
    (["hello", "world"], None, None, "no usable NMEA"),
    ([GGA], 1, "date", "carry no date"),
    ([sentence("GPGGA,123519,48xx.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,")], 1, "GPGGA latitude", "ddmm"),
    ([RMC, sentence("GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,abc,M,46.9,M,,")], 2, "GPGGA altitude",
     "number"),
    ([sentence("GPRMC,126519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W")], 1, "GPRMC time", "hhmmss"),
    ([sentence("GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,320394,003.1,W")], 1, "GPRMC date", "ddmmyy"),
    ([sentence("GPRMC,123519,A,4807.038,N,01131.000,E,-2,084.4,230394,,")], 1, "GPRMC speed", "negative"),
    ([sentence("GPGGA,123519,4807.038,N,01131.000,E,1,08,-2.83,545.4,M,46.9,M,,")], 1, "GPGGA HDOP", ">= 0"),
    ([RMC, sentence("GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,-2.1")], 2, "GPGSA VDOP", ">= 0"),
    (epoch("120000.20") + epoch("120000.00"), 3, "time", "backwards"),
    (epoch("120000.20") + epoch("120000.40") + epoch("120000.20"), 5, "time", "backwards"),
])
def test_broken_files_located(tmp_path, capsys, lines, line, field, what):
    f = write(tmp_path, lines)
    with pytest.raises(InputError) as err:
        read_nmea(f)
    assert err.value.line == line and err.value.field == field and what in err.value.message
    assert main(["inspect", str(f)]) == 2
    out = capsys.readouterr()
    assert out.err.strip().count("\n") == 0 and out.err.startswith(f"casrecon: {f}")
    assert "Traceback" not in out.err


def test_a_log_whose_first_lines_are_proprietary_is_nmea(tmp_path, capsys):
    """A logger's own ``$P...`` sentences (version, IMU, temperature) ahead of the fixes: recognised
    as NMEA by inspect and the GPS readers, the proprietary lines skipped and counted."""
    head = [sentence("PVER,logger 2.1"), sentence("PIMU,123519.00,0.01,-0.02,9.81,0.1,0.2,0.3"),
            sentence("PTH,21.5,45.0"), sentence("PIMU,123519.10,0.01,-0.02,9.81,0.1,0.2,0.3")]
    f = write(tmp_path, head + epoch("123519") + epoch("123520"))
    assert gps_file_kind(f.read_text().splitlines()) == "nmea" and input_kind(f)[0] == "nmea"
    track = read_nmea(f)
    assert track.time_unix_s.size == 2 and any("other sentences" in n or "not NMEA" in n for n in track.notes)
    assert main(["inspect", str(f)]) == 0
    assert "Traceback" not in capsys.readouterr().err


def test_a_file_of_other_dollar_lines_is_not_nmea():
    assert not is_nmea(["$FLYS,1", "$VAR,FIRMWARE_VER,v2023.09.22", "$COL,GNSS,time,lat,lon"])
    assert not is_nmea(["$P,1,2", "$PX,3"])  # a bare $P is no maker's code
