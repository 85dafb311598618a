"""NMEA sentences as navd's frames: position, ellipsoidal altitude, accuracy by fix quality
and from GST per axis, true heading; fixes not measured left out, and bad or impossible
sentences counted, never fatal."""

from __future__ import annotations

import pytest

from navd.sensors.nmea import RANGE_ERROR_M, UERE_M, NmeaReader
from navd.wire import FixFrame, HeadingFrame


def nmea(body: str) -> str:
    """A sentence with its checksum."""
    checksum = 0
    for char in body:
        checksum ^= ord(char)
    return f"${body}*{checksum:02X}"


GGA = nmea("GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,")


def test_a_gga_gives_a_fix_with_the_hdop_accuracy() -> None:
    (fix,) = NmeaReader().feed((GGA + "\r\n").encode(), stamp=5.0)
    assert isinstance(fix, FixFrame)
    assert fix.latitude == pytest.approx(48.1173) and fix.longitude == pytest.approx(11.516667)
    assert fix.status == 0 and fix.stamp == 5.0
    assert fix.altitude == pytest.approx(545.4 + 46.9)  # above the ellipsoid, not the geoid
    assert fix.horizontal_accuracy == pytest.approx(0.9 * UERE_M)


def test_gst_errors_give_the_accuracy_while_fresh() -> None:
    reader = NmeaReader()
    gst = nmea("GNGST,172814.0,0.006,0.023,0.020,273.6,0.03,0.04,0.031")
    reader.line(gst, stamp=1.0)
    (fix,) = reader.feed((GGA + "\n").encode(), stamp=1.5)
    # 0.03 m along latitude, 0.04 m along longitude: each axis's sigma is at most 0.04 m
    assert isinstance(fix, FixFrame) and fix.horizontal_accuracy == pytest.approx(0.04)
    (old,) = reader.feed((GGA + "\n").encode(), stamp=10.0)  # the GST is too old by now
    assert isinstance(old, FixFrame) and old.horizontal_accuracy == pytest.approx(0.9 * UERE_M)


@pytest.mark.parametrize(
    ("quality", "status", "accuracy_m"),
    [("0", -1, 3.6), ("1", 0, 3.6), ("2", 1, 0.9), ("5", 2, 0.27), ("4", 2, 0.018)],
)
def test_fix_quality_sets_the_status_and_without_gst_the_accuracy(
    quality: str, status: int, accuracy_m: float
) -> None:
    gga = nmea(f"GNGGA,123519,4807.038,N,01131.000,E,{quality},08,0.9,545.4,M,46.9,M,,")
    fix = NmeaReader().line(gga, stamp=0.0)
    assert isinstance(fix, FixFrame) and fix.status == status
    assert fix.horizontal_accuracy == pytest.approx(accuracy_m)
    assert RANGE_ERROR_M[4] <= 0.05  # RTK fixed is centimetres


@pytest.mark.parametrize("quality", ["6", "7", "8"])
def test_a_fix_the_receiver_did_not_measure_is_left_out(quality: str) -> None:
    reader = NmeaReader()
    gga = nmea(f"GNGGA,123519,4807.038,N,01131.000,E,{quality},08,0.9,545.4,M,46.9,M,,")
    assert reader.line(gga, stamp=0.0) is None and reader.not_measured == 1


def test_impossible_values_are_counted_not_fatal() -> None:
    reader = NmeaReader()
    north_of_the_pole = nmea("GPGGA,123519,9959.940,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,")
    assert reader.line(north_of_the_pole, stamp=0.0) is None
    assert reader.out_of_range == 1
    assert isinstance(reader.line(GGA, stamp=0.1), FixFrame)  # and the next one is read


def test_a_void_rmc_marks_positions_invalid_until_valid_again() -> None:
    reader = NmeaReader()
    reader.line(nmea("GPRMC,123519,V,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W"), 0.0)
    fix = reader.line(GGA, 0.1)
    assert isinstance(fix, FixFrame) and fix.status == -1
    reader.line(nmea("GPRMC,123520,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W"), 0.2)
    fix = reader.line(GGA, 0.3)
    assert isinstance(fix, FixFrame) and fix.status == 0


def test_hdt_gives_a_true_heading() -> None:
    heading = NmeaReader().line(nmea("GPHDT,274.07,T"), 2.0)
    assert isinstance(heading, HeadingFrame)
    assert heading.bearing_deg == pytest.approx(274.07) and heading.true_north


def test_bad_sentences_are_counted_and_skipped_and_lines_may_come_in_pieces() -> None:
    reader = NmeaReader()
    corrupt = GGA[:-2] + "00"
    frames = reader.feed(f"{corrupt}\r\nnoise\r\n$GPXXX,1,2*00\r\n".encode(), 0.0)
    assert frames == [] and reader.bad_checksums >= 1 and reader.unparsed >= 1
    half = len(GGA) // 2
    assert reader.feed(GGA[:half].encode(), 1.0) == []
    assert len(reader.feed((GGA[half:] + "\n").encode(), 1.1)) == 1
