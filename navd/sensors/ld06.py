"""LDRobot LD06 / LD19 / STL-19P lidars: their serial packets, and whole turns as scans.

Written from LDRobot's published protocol (the LD06 and LD19 development manuals). The
lidar streams 47-byte packets at 230400 baud, each carrying 12 points:

====== ======== =============================================================
bytes  field    meaning
====== ======== =============================================================
0      header   0x54
1      ver_len  0x2C (the low 5 bits: 12 points)
2-3    speed    [deg/s] rotation speed, little-endian
4-5    start    [0.01 deg] angle of the first point
6-41   points   12 x (distance [mm] u16, intensity u8)
42-43  end      [0.01 deg] angle of the last point
44-45  time     [ms] the lidar's clock, wrapping at 30000
46     crc      CRC-8 (polynomial 0x4D, initial 0, not reflected) of bytes 0-45
====== ======== =============================================================

Angles grow clockwise seen from above (the lidar turns clockwise), from its front (the
cable side faces back). A point's angle is interpolated between the packet's start and end.
A distance of 0 is no return. The time field is read as the lidar's clock when the
packet's last point was measured; ``device_clock`` places it on this computer's clock, and
each point is that time less the points after it (their spacing over the speed). A turn ends
at the point where the angle passes 0 (inside a packet, not at the packet's end) and is sent
at once, as one ScanFrame in the order its rays were measured (``revolution_scan``), with
the intensities and the time between rays.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from navd.sensors.device_clock import DeviceClock
from navd.sensors.turn_builder import TurnBuilder
from navd.wire import ScanFrame

__all__ = [
    "PACKET_BYTES",
    "RANGE_MAX_M",
    "Ld06Packet",
    "PacketReader",
    "ScanAssembler",
    "crc8",
    "encode_packet",
]

HEADER = 0x54
VER_LEN = 0x2C
POINTS = 12
PACKET_BYTES = 47
POLYNOMIAL = 0x4D
RANGE_MIN_M = 0.02
RANGE_MAX_M = 12.0
BAUD = 230400
PACKET_LINE_S = PACKET_BYTES * 10 / BAUD  # [s] a packet's time on the line (8N1)
CLOCK_WRAP_S = 30.0  # [s] the lidar's millisecond counter wraps at 30000
_PACKET = struct.Struct("<BBHH" + "HB" * POINTS + "HHB")


def _table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ POLYNOMIAL) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


_CRC_TABLE = _table()


def crc8(data: bytes) -> int:
    """The LD06's CRC-8 of ``data``."""
    crc = 0
    for byte in data:
        crc = _CRC_TABLE[(crc ^ byte) & 0xFF]
    return crc


@dataclass(frozen=True, slots=True)
class Ld06Packet:
    """One packet: [deg/s], [deg] clockwise, [m], intensities, [ms] of the lidar's clock."""

    speed_dps: float
    start_deg: float
    end_deg: float
    distances_m: tuple[float, ...]
    intensities: tuple[int, ...]
    time_ms: int

    def angles_deg(self) -> npt.NDArray[np.float64]:
        """[deg] clockwise angle of each point (interpolated, across 360 when it wraps)."""
        span = (self.end_deg - self.start_deg) % 360.0
        return (self.start_deg + span * np.arange(POINTS) / (POINTS - 1)) % 360.0


def encode_packet(
    speed_dps: float, start_deg: float, end_deg: float, distances_m: list[float], time_ms: int
) -> bytes:
    """A packet as the lidar sends it (for tests and the simulator)."""
    fields: list[int] = [HEADER, VER_LEN, round(speed_dps), round(start_deg * 100) % 36000]
    for d in distances_m:
        fields += [round(d * 1000), 200 if d > 0 else 0]
    fields += [round(end_deg * 100) % 36000, time_ms % 30000]
    body = _PACKET.pack(*fields, 0)[:-1]
    return body + bytes([crc8(body)])


def _decode(raw: bytes) -> Ld06Packet:
    values = _PACKET.unpack(raw)
    points = values[4 : 4 + 2 * POINTS]
    return Ld06Packet(
        speed_dps=float(values[2]),
        start_deg=values[3] / 100.0,
        end_deg=values[4 + 2 * POINTS] / 100.0,
        distances_m=tuple(d / 1000.0 for d in points[0::2]),
        intensities=tuple(points[1::2]),
        time_ms=values[5 + 2 * POINTS],
    )


@dataclass
class PacketReader:
    """Bytes from the serial port in, whole packets out; what cannot be a packet is
    skipped to the next header and counted.

    Attributes:
        skipped_bytes: bytes that were not part of a good packet.
        bad_checksums: packets whose CRC did not match (dropped).
    """

    skipped_bytes: int = 0
    bad_checksums: int = 0
    _buffer: bytearray = field(default_factory=bytearray)

    def feed(self, data: bytes) -> list[Ld06Packet]:
        """Take ``data``; the packets it completed."""
        return [packet for packet, _ in self.feed_timed(data, 0.0)]

    def feed_timed(self, data: bytes, read_s: float) -> list[tuple[Ld06Packet, float]]:
        """Take ``data``, read at ``read_s`` [s]; the packets it completed, each with when
        it arrived at the latest (``read_s`` less the time on the line of the bytes after
        it in ``data``)."""
        buffer = self._buffer
        buffer.extend(data)
        packets: list[tuple[Ld06Packet, float]] = []
        while True:
            start = buffer.find(bytes([HEADER, VER_LEN]))
            if start < 0:
                keep = 1 if buffer and buffer[-1] == HEADER else 0
                self.skipped_bytes += len(buffer) - keep
                del buffer[: len(buffer) - keep]
                return packets
            if start:
                self.skipped_bytes += start
                del buffer[:start]
            if len(buffer) < PACKET_BYTES:
                return packets
            raw = bytes(buffer[:PACKET_BYTES])
            if crc8(raw[:-1]) != raw[-1]:
                self.bad_checksums += 1
                self.skipped_bytes += 1
                del buffer[:1]  # look for the next header inside it
                continue
            del buffer[:PACKET_BYTES]
            after = len(buffer) if len(buffer) < len(data) else len(data)
            packets.append((_decode(raw), read_s - after * PACKET_LINE_S / PACKET_BYTES))


class ScanAssembler:
    """Packets in, one ScanFrame per turn out (see the module docstring).

    Args:
        min_intensity: points below this intensity are taken as no return.
        range_max_m: [m] the longest range trusted (the LD06's 12 m unless told).
    """

    def __init__(self, min_intensity: int = 1, range_max_m: float = RANGE_MAX_M) -> None:
        self.min_intensity = min_intensity
        self.clock = DeviceClock(CLOCK_WRAP_S)
        self.turns = TurnBuilder(RANGE_MIN_M, range_max_m)

    def add(self, packet: Ld06Packet, arrived_s: float) -> ScanFrame | None:
        """Take a packet that arrived at ``arrived_s`` [s, this computer's clock] at the
        latest; the turn it completed, if it did."""
        scans = self.add_many([(packet, arrived_s)])
        return scans[-1] if scans else None

    def add_many(self, packets: list[tuple[Ld06Packet, float]]) -> list[ScanFrame]:
        """Take packets of one read, each with when it arrived at the latest; the turns
        they completed (one pass over all their points)."""
        if not packets:
            return []
        count = len(packets)
        last_s = np.empty(count)
        point_s = np.empty(count)
        angles = np.empty((count, POINTS))
        for k, (packet, arrived_s) in enumerate(packets):
            last_s[k] = self.clock.host_time(packet.time_ms / 1000.0, arrived_s - PACKET_LINE_S)
            span = (packet.end_deg - packet.start_deg) % 360.0
            point_s[k] = span / (POINTS - 1) / packet.speed_dps if packet.speed_dps > 0 else 0.0
            angles[k] = packet.start_deg + span * _FRACTIONS
        times = last_s[:, None] - point_s[:, None] * _POINTS_AFTER
        ranges = np.array([p.distances_m for p, _ in packets], dtype=np.float64)
        intensities = np.array([p.intensities for p, _ in packets], dtype=np.float64)
        ranges[(ranges <= 0.0) | (intensities < self.min_intensity)] = np.nan
        return self.turns.add(
            np.mod(angles, 360.0).ravel(), ranges.ravel(), times.ravel(), intensities.ravel()
        )


_FRACTIONS = np.arange(POINTS) / (POINTS - 1)  # a point's place between start and end
_POINTS_AFTER = np.arange(POINTS - 1, -1, -1, dtype=np.float64)  # points after it
