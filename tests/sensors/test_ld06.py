"""LD06 packets: the CRC, decoding, finding packets in a noisy stream; and turns as scans in
the order measured, each ray centred on its angle and stamped by the lidar's own clock, sent
the moment the turn ends. The packets come from the emulated device (``navd.sim.devices``,
itself checked against lds2d), not from navd's encoder."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navd.sensors.ld06 import (
    PACKET_BYTES,
    PacketReader,
    ScanAssembler,
    crc8,
    encode_packet,
)
from navd.sim.devices import Ld06Device
from navd.wire import ScanFrame


def _bitwise_crc8(data: bytes) -> int:
    """The LD06 CRC computed bit by bit (polynomial 0x4D, MSB first), not from a table."""
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x4D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def room(angle_cw_deg: float) -> tuple[float, int]:
    """A wall 1 m away on the lidar's left (260-280 deg clockwise), 3 m elsewhere."""
    return (1.0, 200) if 260.0 <= angle_cw_deg <= 280.0 else (3.0, 90)


def _ranges(scan: ScanFrame) -> np.ndarray:
    return np.array([np.nan if r is None else r for r in scan.ranges or []], dtype=float)


def _turns(device: Ld06Device, seconds: float, delays: np.ndarray | None = None) -> list[ScanFrame]:
    """Each packet of ``seconds`` read ``delays`` late (one per packet; none: at once)."""
    reader, turns = PacketReader(), ScanAssembler()
    scans: list[ScanFrame] = []
    packets = itertools.takewhile(lambda p: p[0] < 50.0 + seconds, device.packets(50.0))
    for k, (ready, packet) in enumerate(packets):
        late = 0.0 if delays is None else float(delays[k])
        for read, arrived in reader.feed_timed(packet, ready + PACKET_BYTES * 10 / 230400 + late):
            scan = turns.add(read, arrived)
            if scan is not None:
                scans.append(scan)
    return scans


def test_the_crc_is_the_polynomial_0x4d() -> None:
    rng = np.random.default_rng(3)
    for _ in range(50):
        data = rng.integers(0, 256, size=46, dtype=np.uint8).tobytes()
        assert crc8(data) == _bitwise_crc8(data)


def test_a_packet_reads_back_as_sent() -> None:
    distances = [0.5 + 0.1 * i for i in range(12)]
    packet = encode_packet(3600, 10.0, 18.8, distances, time_ms=1234)
    assert len(packet) == PACKET_BYTES and packet[:2] == b"\x54\x2c"
    (read,) = PacketReader().feed(packet)
    assert read.speed_dps == 3600 and (read.start_deg, read.end_deg) == (10.0, 18.8)
    assert read.distances_m == pytest.approx(tuple(distances), abs=1e-3)
    assert read.time_ms == 1234
    np.testing.assert_allclose(read.angles_deg()[[0, -1]], [10.0, 18.8])


def test_packets_are_found_in_noise_and_bad_ones_counted() -> None:
    good = encode_packet(3600, 0.0, 8.8, [1.0] * 12, 0)
    broken = bytearray(good)
    broken[10] ^= 0xFF  # a flipped byte: the CRC no longer matches
    reader = PacketReader()
    stream = b"\x00\x54garbage" + bytes(broken) + good[:20]
    assert reader.feed(stream) == []
    assert len(reader.feed(good[20:] + good)) == 2  # split across reads: still whole
    assert reader.bad_checksums == 1 and reader.skipped_bytes >= len(b"\x00\x54garbage")


def test_a_turn_is_one_scan_in_the_order_measured_with_its_intensities() -> None:
    """The lidar turns clockwise from its front: the scan's first ray points ahead, its
    increment is negative, and the wall on the left (270 deg clockwise) is at +90 deg."""
    scan = _turns(Ld06Device(room), 0.35)[1]
    assert scan.angle_min == pytest.approx(0.0, abs=1e-9)
    assert scan.angle_increment == pytest.approx(-2 * math.pi / 720)
    assert scan.time_increment == pytest.approx(0.1 / 720, rel=0.02)
    ranges = _ranges(scan)
    angles = np.remainder(scan.angle_min + scan.angle_increment * np.arange(ranges.size), 2 * np.pi)
    left = np.abs(angles - math.pi / 2) < math.radians(9)
    elsewhere = np.abs(angles - math.pi / 2) > math.radians(11)
    seen = np.isfinite(ranges)
    assert np.allclose(ranges[left & seen], 1.0) and np.allclose(ranges[elsewhere & seen], 3.0)
    strengths = np.array([np.nan if v is None else v for v in scan.intensities or []], dtype=float)
    assert np.all(strengths[left & np.isfinite(ranges)] == 200)


def test_each_point_goes_to_the_ray_centred_on_it() -> None:
    """A ray is centred on its angle: over many points the mean offset from the ray's angle
    to the point's is nil (a ray that took its bin's lower edge turned every scan 0.25 deg)."""
    turns = ScanAssembler()
    rng = np.random.default_rng(8)
    truth = np.sort(rng.uniform(0.0, 359.0, 400))
    offsets = []
    for angle in truth:
        single = np.full(12, 0.0)
        single[0] = 2.0
        packet = encode_packet(3600, angle, angle + 0.88, list(single), 0)
        (read,) = PacketReader().feed(packet)
        turns.add(read, 1.0)
        scan = turns.turns.end_turn()
        assert scan is not None
        k = int(np.flatnonzero(np.isfinite(_ranges(scan)))[0])
        ray_deg = -math.degrees(scan.angle_min + scan.angle_increment * k)
        offsets.append((ray_deg - angle + 180.0) % 360.0 - 180.0)
    assert abs(float(np.mean(offsets))) < 0.03
    assert max(abs(o) for o in offsets) <= 0.25 + 0.006  # (the packet holds 0.01 deg)


def test_turns_are_stamped_by_the_lidars_clock_however_late_they_are_read() -> None:
    device = Ld06Device(room, clock_start_ms=29_000)  # its clock wraps in the first second
    rng = np.random.default_rng(2)
    packets = 4 * 10 * 38
    # late by up to 3 ms always, and now and then by up to 120 ms (a busy machine)
    delays = rng.uniform(0.0, 0.003, packets) + np.where(
        rng.uniform(size=packets) < 0.03, rng.uniform(0.0, 0.12, packets), 0.0
    )
    scans = _turns(device, 4.0, delays)
    truth = {round(turn.first_s, 3): turn for turn in device.turns}
    checked = 0
    for scan in scans[10:]:  # after the first second the clock offset is known
        turn = min(device.turns, key=lambda t: abs(t.first_s - scan.stamp))
        assert scan.stamp == pytest.approx(turn.first_s, abs=0.004)
        checked += 1
    assert checked >= 25 and truth


def test_a_turn_is_sent_with_the_packet_that_passes_the_front() -> None:
    device = Ld06Device(room)
    reader, turns = PacketReader(), ScanAssembler()
    for ready, packet in itertools.takewhile(lambda p: p[0] < 50.25, device.packets(50.0)):
        (read,) = reader.feed(packet)
        wraps = read.end_deg < read.start_deg or read.start_deg < 1.0
        scan = turns.add(read, ready + 0.002)
        if scan is not None:  # sent at the packet holding the turn's end, not one later
            assert wraps
