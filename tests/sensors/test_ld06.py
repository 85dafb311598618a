"""LD06 packets: the CRC, decoding, finding packets in a noisy stream, and turns as scans."""

from __future__ import annotations

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


def _bitwise_crc8(data: bytes) -> int:
    """The LD06 CRC computed bit by bit (polynomial 0x4D, MSB first), not from a table."""
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x4D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


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


def test_a_turn_becomes_one_counter_clockwise_scan() -> None:
    """A wall 2 m away on the lidar's left (90 deg clockwise is its right): the scan shows
    it at +90 deg in the ROS convention only if the clockwise angles are turned around."""
    turns = ScanAssembler()
    frames = []
    for turn in range(2):
        for k in range(30):  # 30 packets of 12 points: 360 deg
            start = 12.0 * k
            distances = [2.0 if 260 <= start + i <= 280 else 0.0 for i in range(12)]
            frame = turns.add(encode_and_read(start, start + 11.0, distances), 0.1 * turn + k)
            if frame is not None:
                frames.append(frame)
    assert len(frames) == 1  # the first turn, completed when the second began
    scan = frames[0]
    ranges = np.array([np.nan if r is None else r for r in scan.ranges], dtype=float)
    angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
    seen = angles[np.isfinite(ranges)]
    # 270 deg clockwise from the front is 90 deg counter-clockwise: the left
    assert seen.min() > math.radians(75) and seen.max() < math.radians(105)
    assert np.nanmin(ranges) == pytest.approx(2.0)
    assert scan.stamp == 0.0  # the turn's first packet


def encode_and_read(start: float, end: float, distances: list[float]) -> object:
    (packet,) = PacketReader().feed(encode_packet(3600, start, end, distances, 0))
    return packet
