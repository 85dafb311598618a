"""Any NMEA 0183 GNSS receiver: sentences in, fix and heading frames out (parsed with
pynmea2).

- GGA gives the position, the altitude and the fix quality (0: no fix, sent as ``status``
  -1 so navd ignores it; 1: GPS, ``status`` 0; 2: DGPS/SBAS, 1; 4 and 5: RTK, 2);
- GST gives the position's 1-sigma errors: the horizontal accuracy is their root sum of
  squares; without GST it is the HDOP times ``UERE_M`` (a typical single-receiver error);
- RMC with status V (void) marks the position invalid until an A comes;
- VTG is read and not sent (navd estimates velocity itself);
- HDT, from a dual-antenna receiver, gives a true heading (a ``heading`` frame with
  ``true_north``), of accuracy ``HDT_ACCURACY_DEG``.

Sentences with a bad checksum or that cannot be parsed are counted and skipped; talkers (GP,
GN, GL, GA...) are all accepted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import pynmea2

from navd.wire import FixFrame, HeadingFrame, SensorFrame

__all__ = ["HDT_ACCURACY_DEG", "UERE_M", "NmeaReader"]

UERE_M = 4.0  # [m] user equivalent range error of a plain receiver: accuracy = HDOP x this
HDT_ACCURACY_DEG = 1.0  # [deg] what a dual-antenna heading is taken to be good to
GST_MAX_AGE_S = 2.0  # [s] a GST older than this no longer tells the accuracy
_RTK = {4, 5}


@dataclass
class NmeaReader:
    """NMEA lines in, frames out.

    Attributes:
        bad_checksums: sentences whose checksum did not match.
        unparsed: sentences pynmea2 could not read (or not NMEA at all).
    """

    bad_checksums: int = 0
    unparsed: int = 0
    _accuracy_m: float | None = None
    _accuracy_at: float = -math.inf
    _valid: bool = True
    _pending: bytearray = field(default_factory=bytearray)

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        """Take bytes read at ``stamp`` [s]; the frames of the whole lines among them."""
        self._pending.extend(data)
        frames: list[SensorFrame] = []
        while (end := self._pending.find(b"\n")) >= 0:
            line = bytes(self._pending[:end]).strip()
            del self._pending[: end + 1]
            frame = self.line(line.decode("ascii", errors="replace"), stamp)
            if frame is not None:
                frames.append(frame)
        if len(self._pending) > 4096:  # no line end in sight: not NMEA
            self.unparsed += 1
            self._pending.clear()
        return frames

    def line(self, text: str, stamp: float) -> SensorFrame | None:
        """One sentence read at ``stamp`` [s]: its frame, if it makes one."""
        if not text.startswith("$"):
            if text:
                self.unparsed += 1
            return None
        try:
            sentence = pynmea2.parse(text, check=True)
        except pynmea2.ChecksumError:
            self.bad_checksums += 1
            return None
        except (pynmea2.ParseError, ValueError, AttributeError):
            self.unparsed += 1
            return None
        kind = type(sentence).__name__
        if kind == "GST":
            self._gst(sentence, stamp)
            return None
        if kind == "RMC":
            self._valid = getattr(sentence, "status", "A") == "A"
            return None
        if kind == "GGA":
            return self._gga(sentence, stamp)
        if kind == "HDT":
            return self._hdt(sentence, stamp)
        return None  # VTG, GSA, GSV...: nothing navd uses

    def _gst(self, sentence: Any, stamp: float) -> None:
        try:
            lat = float(getattr(sentence, "std_dev_latitude", "") or "nan")
            lon = float(getattr(sentence, "std_dev_longitude", "") or "nan")
        except ValueError:
            self.unparsed += 1
            return
        if math.isfinite(lat) and math.isfinite(lon) and lat > 0 and lon > 0:
            self._accuracy_m = math.hypot(lat, lon)
            self._accuracy_at = stamp

    def _gga(self, sentence: Any, stamp: float) -> FixFrame | None:
        try:
            quality = int(getattr(sentence, "gps_qual", 0) or 0)
            latitude = float(sentence.latitude)
            longitude = float(sentence.longitude)
            altitude = float(getattr(sentence, "altitude", 0.0) or 0.0)
            hdop = float(getattr(sentence, "horizontal_dil", "") or "nan")
        except (TypeError, ValueError):
            self.unparsed += 1
            return None
        accuracy = self._accuracy_m if stamp - self._accuracy_at <= GST_MAX_AGE_S else None
        if accuracy is None:
            accuracy = hdop * UERE_M if math.isfinite(hdop) and hdop > 0 else 99.0
        # sensor_msgs/NavSatStatus: -1 no fix, 0 fix, 1 with satellite augmentation (DGPS,
        # SBAS), 2 with ground-based augmentation (RTK)
        if quality == 0 or not self._valid:
            status = -1
        elif quality in _RTK:
            status = 2
        else:
            status = 1 if quality == 2 else 0
        return FixFrame(
            stamp=stamp,
            latitude=latitude,
            longitude=longitude,
            altitude=altitude,
            horizontal_accuracy=accuracy,
            status=status,
        )

    def _hdt(self, sentence: Any, stamp: float) -> HeadingFrame | None:
        try:
            heading = float(sentence.heading)
        except (TypeError, ValueError):
            self.unparsed += 1
            return None
        return HeadingFrame(
            stamp=stamp,
            bearing_deg=heading % 360.0,
            accuracy_deg=HDT_ACCURACY_DEG,
            true_north=True,
        )
