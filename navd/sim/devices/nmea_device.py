"""A GNSS receiver speaking NMEA 0183, as the standard describes its sentences.

Each epoch (``rate_hz`` a second, on the second) it sends GGA (position, fix quality,
satellites, HDOP, altitude above the geoid and the geoid's separation), RMC (status A, or V
without a fix), VTG, and when asked GST (1-sigma errors along latitude and longitude) and
HDT (a dual-antenna true heading), each with its checksum and CR LF, back to back at the
receiver's baud rate (``UartWriter``). Where the receiver is, its quality and its errors
are the test's to set at any time (``state``).

Sentences are written here from the standard's field lists, not with navd's reader or with
pynmea2; the tests read them with pynmea2, an independent parser, and with navd's program.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field, replace

from navd.sim.devices.serial_line import SerialLine, UartWriter

__all__ = ["GnssState", "NmeaDevice", "nmea_sentence"]


def nmea_sentence(body: str) -> bytes:
    """``$body*CS`` with CR LF: CS the XOR of the body's characters, two hex digits."""
    checksum = 0
    for char in body:
        checksum ^= ord(char)
    return f"${body}*{checksum:02X}\r\n".encode("ascii")


def _lat(deg: float) -> str:
    d = abs(deg)
    return f"{int(d):02d}{(d - int(d)) * 60:07.4f},{'N' if deg >= 0 else 'S'}"


def _lon(deg: float) -> str:
    d = abs(deg)
    return f"{int(d):03d}{(d - int(d)) * 60:07.4f},{'E' if deg >= 0 else 'W'}"


@dataclass(frozen=True, slots=True)
class GnssState:
    """What the receiver reports at the next epochs.

    Attributes:
        latitude_deg, longitude_deg: where its antenna is.
        altitude_m: above the geoid; geoid_separation_m: the geoid above the ellipsoid.
        quality: GGA's fix quality (0 none, 1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float, 6
            dead reckoning); satellites, hdop: as GGA gives them.
        sigma_lat_m, sigma_lon_m: GST's errors (None: no GST).
        heading_deg: HDT's true heading (None: no HDT).
    """

    latitude_deg: float = 48.1173
    longitude_deg: float = 11.516667
    altitude_m: float = 545.4
    geoid_separation_m: float = 46.9
    quality: int = 1
    satellites: int = 8
    hdop: float = 0.9
    sigma_lat_m: float | None = None
    sigma_lon_m: float | None = None
    heading_deg: float | None = None


@dataclass
class NmeaDevice:
    """The receiver: ``stream`` sends its epochs on a serial line until stopped.

    Attributes:
        state: what it reports (replace it to move the receiver or change its fix).
        rate_hz: epochs a second; baud: its line's rate.
        epochs: the epochs sent, [s] when each began; frozen: set to hang it.
    """

    state: GnssState = field(default_factory=GnssState)
    rate_hz: float = 1.0
    baud: int = 9600
    epochs: list[float] = field(default_factory=list)
    frozen: threading.Event = field(default_factory=threading.Event)

    def set(self, **changes: object) -> None:
        """Change what the next epochs report."""
        self.state = replace(self.state, **changes)  # type: ignore[arg-type]

    def epoch(self, at_s: float) -> bytes:
        """Every sentence of the epoch at ``at_s`` [s since midnight UTC, as the time
        fields give it]."""
        s = self.state
        hms = time.strftime("%H%M%S", time.gmtime(at_s)) + f".{int(at_s * 100) % 100:02d}"
        where = f"{_lat(s.latitude_deg)},{_lon(s.longitude_deg)}"
        fixed = s.quality > 0
        out = nmea_sentence(
            f"GNGGA,{hms},{where},{s.quality},{s.satellites:02d},{s.hdop:.1f},"
            f"{s.altitude_m:.1f},M,{s.geoid_separation_m:.1f},M,,"
        )
        date = time.strftime("%d%m%y", time.gmtime(at_s))
        out += nmea_sentence(f"GNRMC,{hms},{'A' if fixed else 'V'},{where},0.0,0.0,{date},,,A")
        out += nmea_sentence("GNVTG,0.0,T,,M,0.0,N,0.0,K,A")
        if s.sigma_lat_m is not None and s.sigma_lon_m is not None:
            rms = math.hypot(s.sigma_lat_m, s.sigma_lon_m)
            out += nmea_sentence(
                f"GNGST,{hms},{rms:.3f},,,,{s.sigma_lat_m:.3f},{s.sigma_lon_m:.3f},"
                f"{2 * s.sigma_lat_m:.3f}"
            )
        if s.heading_deg is not None:
            out += nmea_sentence(f"GNHDT,{s.heading_deg % 360.0:.2f},T")
        return out

    def stream(self, line: SerialLine, stop: threading.Event) -> None:
        """Send an epoch every 1/``rate_hz`` s, on the clock's own ticks, until stopped."""
        writer = UartWriter(line.fd, self.baud)
        period = 1.0 / self.rate_hz
        next_s = math.ceil(time.time() / period) * period
        while not stop.is_set():
            if stop.wait(max(next_s - time.time(), 0.0)):
                return
            if not self.frozen.is_set():
                self.epochs.append(time.monotonic())
                writer.send(self.epoch(next_s), time.monotonic())
            next_s += period
