"""An LDRobot LD06 (also the LD19 and STL-19P) as its development manual describes it.

The lidar turns clockwise at ``rate_hz`` and measures ``sample_hz`` points a second. Every
12 points it sends a 47-byte packet at 230400 baud: the speed [deg/s], the first and last
point's angles [0.01 deg], each point's distance [mm] and intensity, and its own clock [ms,
wrapping at 30000] read when the packet's last point was measured; CRC-8 (polynomial 0x4D)
last. The packet is ready when its last point is measured and takes 2 ms on the line
(``UartWriter``), so packets leave back to back with short gaps, as on a real LD06. The
clock runs from a random-looking start and may drift (``drift_ppm``) against this computer's.

Bytes are made here from the manual's table, not with navd's ``sensors.ld06``; the tests read
them with lds2d, an independent driver, and with navd's program.
"""

from __future__ import annotations

import math
import struct
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

from navd.sim.devices.serial_line import SerialLine, UartWriter

__all__ = ["LD06_BAUD", "Ld06Device", "Ld06Turn", "ld06_packet"]

LD06_BAUD = 230400
POINTS = 12
CLOCK_WRAP_MS = 30000


def _crc8(data: bytes) -> int:
    """CRC-8, polynomial 0x4D, initial 0, most significant bit first (bit by bit)."""
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x4D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def ld06_packet(
    speed_dps: int,
    start_cdeg: int,
    end_cdeg: int,
    points: list[tuple[int, int]],
    clock_ms: int,
) -> bytes:
    """One packet: 0x54 0x2C, speed, start angle, 12 (distance [mm], intensity), end angle,
    clock, CRC. Angles in 0.01 deg (0-35999), little-endian."""
    body = struct.pack("<BBHH", 0x54, 0x2C, speed_dps, start_cdeg % 36000)
    for distance_mm, intensity in points:
        body += struct.pack("<HB", distance_mm, intensity)
    body += struct.pack("<HH", end_cdeg % 36000, clock_ms % CLOCK_WRAP_MS)
    return body + bytes([_crc8(body)])


@dataclass(frozen=True, slots=True)
class Ld06Turn:
    """One turn as the device measured it: [s, time.monotonic] of its first and last
    points (a turn begins where the angle passes 0, the lidar's front)."""

    first_s: float
    last_s: float


@dataclass
class Ld06Device:
    """The device: ``stream`` sends its packets on a serial line until stopped.

    Args:
        room: (range [m], intensity 0-255) at a clockwise angle [deg]; range 0 is no return.
        rate_hz: turns a second.
        sample_hz: points measured a second.
        clock_start_ms: the device clock's reading when streaming starts.
        drift_ppm: how much faster the device clock runs than this computer's.

    Attributes:
        turns: every turn completed so far.
        frozen: set to make the device stop sending (a hung lidar; the line stays open).
        packets_sent: packets written to the line.
    """

    room: Callable[[float], tuple[float, int]]
    rate_hz: float = 10.0
    sample_hz: float = 4500.0
    clock_start_ms: int = 17_345
    drift_ppm: float = 0.0
    turns: list[Ld06Turn] = field(default_factory=list)
    frozen: threading.Event = field(default_factory=threading.Event)
    packets_sent: int = 0

    def packets(self, start_s: float) -> Iterator[tuple[float, bytes]]:
        """Every packet from ``start_s`` [s] on, with when it is ready to leave (its last
        point measured); each turn is added to ``turns`` as its end is passed."""
        step_deg = 360.0 * self.rate_hz / self.sample_hz
        speed = round(360.0 * self.rate_hz)
        index = 0  # of the next point
        turn_first_s = start_s
        last = (start_s, 0.0)  # the previous point's time and angle
        while True:
            times = [start_s + (index + i) / self.sample_hz for i in range(POINTS)]
            angles = [((index + i) * step_deg) % 360.0 for i in range(POINTS)]
            for at, angle in zip(times, angles, strict=True):
                if angle < last[1]:  # passed the front: a turn ends
                    self.turns.append(Ld06Turn(turn_first_s, last[0]))
                    turn_first_s = at
                last = (at, angle)
            index += POINTS
            ready_s = times[-1]
            elapsed_ms = (ready_s - start_s) * 1000.0 * (1.0 + self.drift_ppm * 1e-6)
            yield (
                ready_s,
                ld06_packet(
                    speed,
                    round(angles[0] * 100),
                    round(angles[-1] * 100),
                    [self._point(a) for a in angles],
                    self.clock_start_ms + math.floor(elapsed_ms),
                ),
            )

    def stream(self, line: SerialLine, stop: threading.Event) -> None:
        """Send packets in real time until ``stop`` is set (none while frozen)."""
        writer = UartWriter(line.fd, LD06_BAUD)
        for ready_s, packet in self.packets(time.monotonic()):
            wait = ready_s - time.monotonic()
            if wait > 0 and stop.wait(wait):
                return
            if stop.is_set():
                return
            if self.frozen.is_set():
                writer.free_at = 0.0
                continue
            writer.send(packet, ready_s)
            self.packets_sent += 1

    def _point(self, angle_deg: float) -> tuple[int, int]:
        range_m, intensity = self.room(angle_deg)
        if not range_m > 0.0:
            return 0, 0
        return min(round(range_m * 1000.0), 0xFFFF), max(0, min(intensity, 255))
