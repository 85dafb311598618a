"""The emulated LD06 read by lds2d, an independent driver: every point where the room puts
it, packets that pass lds2d's CRC, and bytes that come in the device's rhythm, a few
packets at a time, not a turn at once."""

from __future__ import annotations

import os
import select
import time

import pytest
from lds2d import Lidar
from lds2d.transport import SerialTransport

from navd.sim.devices import Ld06Device
from tests.sim.devices.conftest import streaming


def room(angle_cw_deg: float) -> tuple[float, int]:
    """A wall 1.2 m away on the lidar's right (80-100 deg clockwise), 2.5 m elsewhere;
    nothing comes back from straight behind (175-185 deg)."""
    if 175.0 <= angle_cw_deg <= 185.0:
        return 0.0, 0
    return (1.2, 220) if 80.0 <= angle_cw_deg <= 100.0 else (2.5, 120)


def test_lds2d_reads_the_room_the_device_measures() -> None:
    device = Ld06Device(room)
    with streaming(device.stream) as line:
        lidar = Lidar.open("LD06", transport=SerialTransport(str(line.path), 230400, timeout=2))
        scans = []
        for scan in lidar.scans():
            scans.append(scan)
            if len(scans) == 3:
                break
        lidar.close()
    turn = scans[1]  # the first may start mid-turn
    assert 440 <= len(turn) <= 460  # 4500 points a second, ten turns
    assert turn.scan_freq_hz == pytest.approx(10.0)
    checked = 0
    for point in turn:
        if min(abs(point.angle_deg - edge) for edge in (80, 100, 175, 185)) < 0.5:
            continue  # lds2d spreads a packet's angles evenly, as the manual says: at an
            # edge the rounding of the packet's two angles may put a point either side
        distance, intensity = room(point.angle_deg)
        assert (point.dist_mm, point.quality) == (round(distance * 1000), intensity)
        checked += 1
    assert checked > 400


def test_bytes_arrive_in_the_rhythm_of_the_packets_not_a_turn_at_once() -> None:
    device = Ld06Device(room)
    with streaming(device.stream) as line:
        host = os.open(line.path, os.O_RDONLY | os.O_NONBLOCK)
        reads, total = 0, 0
        end = time.monotonic() + 1.0
        try:
            while time.monotonic() < end:
                if select.select([host], [], [], 0.05)[0]:
                    total += len(os.read(host, 65536))
                    reads += 1
        finally:
            os.close(host)
    # ten turns of 38 packets took a second: a few packets a read, never one burst a turn
    assert total > 5 * 47 * 37
    assert reads > 50
