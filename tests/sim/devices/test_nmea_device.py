"""The emulated GNSS receiver read by pynmea2, an independent parser: every sentence passes
its checksum, and the position, fix, errors and heading are the ones the receiver holds."""

from __future__ import annotations

import os
import select
import time

import pynmea2
import pytest

from navd.sim.devices import NmeaDevice
from navd.sim.devices.nmea_device import GnssState
from tests.sim.devices.conftest import streaming


def test_pynmea2_reads_every_sentence_of_an_epoch() -> None:
    device = NmeaDevice(
        GnssState(
            latitude_deg=-33.8568,
            longitude_deg=151.2153,
            quality=4,
            sigma_lat_m=0.012,
            sigma_lon_m=0.018,
            heading_deg=271.5,
        )
    )
    sentences = [
        pynmea2.parse(line, check=True)
        for line in device.epoch(1_700_000_000.25).decode("ascii").splitlines()
    ]
    by_kind = {type(s).__name__: s for s in sentences}
    assert set(by_kind) == {"GGA", "RMC", "VTG", "GST", "HDT"}
    gga = by_kind["GGA"]
    assert gga.latitude == pytest.approx(-33.8568, abs=1e-6)
    assert gga.longitude == pytest.approx(151.2153, abs=1e-6)
    assert (int(gga.gps_qual), float(gga.altitude), float(gga.geo_sep)) == (4, 545.4, 46.9)
    assert by_kind["RMC"].status == "A"
    gst = by_kind["GST"]
    assert (float(gst.std_dev_latitude), float(gst.std_dev_longitude)) == (0.012, 0.018)
    assert float(by_kind["HDT"].heading) == 271.5


def test_epochs_come_at_the_rate_over_the_line() -> None:
    device = NmeaDevice(rate_hz=5.0, baud=38400)
    with streaming(device.stream) as line:
        host = os.open(line.path, os.O_RDONLY | os.O_NONBLOCK)
        text = b""
        end = time.monotonic() + 1.5
        try:
            while time.monotonic() < end:
                if select.select([host], [], [], 0.05)[0]:
                    text += os.read(host, 4096)
        finally:
            os.close(host)
    # the window can end inside a sentence: only the lines it saw end are read
    whole = text[: text.rfind(b"\n") + 1]
    fixes = [
        pynmea2.parse(s, check=True)
        for s in whole.decode("ascii").splitlines()
        if s.startswith("$GNGGA")
    ]
    assert 5 <= len(fixes) <= 9  # five a second, for a second and a half
