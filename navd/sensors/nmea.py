"""Any NMEA 0183 GNSS receiver: sentences in, fix and heading frames out (parsed with
pynmea2).

- GGA gives the position, the altitude and the fix quality. The quality sets the status
  (sensor_msgs/NavSatStatus: 1 GPS and 3 PPS are 0, a fix; 2 DGPS/SBAS is 1, augmented by
  satellites; 4 RTK fixed and 5 RTK float are 2, augmented from the ground) and, without a
  GST, the accuracy: the HDOP times the error of one range for that kind of fix
  (``RANGE_ERROR_M``: 4 m alone, 1 m with DGPS, 0.3 m RTK float, 0.02 m RTK fixed). 0 (no
  fix) is sent as status -1, which navd ignores; 6 (dead reckoning), 7 (entered by hand) and
  8 (simulated) are not positions the receiver measured: they are counted and not sent. The
  altitude sent is above the WGS84 ellipsoid, as the protocol asks: GGA's height above the
  geoid plus its geoid separation (as given when the receiver leaves the separation out).
- GST gives the position's 1-sigma errors along latitude and longitude: the horizontal
  accuracy is the larger of the two (navd takes it as each axis's sigma), while fresh.
- RMC with status V (void) marks the position invalid until an A comes;
- VTG is read and not sent (navd estimates velocity itself);
- HDT, from a dual-antenna receiver, gives a true heading (a ``heading`` frame with
  ``true_north``) of accuracy ``HDT_ACCURACY_DEG``, sent on the same connection as the fixes
  (navd turns it into the robot's heading through ``mounts.gps.ID.heading_yaw_rad``).

Sentences with a bad checksum or that cannot be parsed are counted and skipped, as are
sentences whose values cannot be (a latitude of 99°): the program never stops on what a
receiver sends. Talkers (GP, GN, GL, GA...) are all accepted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import pynmea2

from navd.wire import FixFrame, HeadingFrame, SensorFrame

__all__ = ["HDT_ACCURACY_DEG", "RANGE_ERROR_M", "UERE_M", "NmeaReader"]

# [m] the error of one range by GGA fix quality: without GST, accuracy = HDOP x this
RANGE_ERROR_M = {1: 4.0, 3: 4.0, 2: 1.0, 5: 0.3, 4: 0.02}
UERE_M = RANGE_ERROR_M[1]  # a plain receiver's
NAVSAT_STATUS = {1: 0, 3: 0, 2: 1, 4: 2, 5: 2}  # by fix quality (see the module docstring)
NOT_MEASURED = {6: "dead_reckoning", 7: "entered_by_hand", 8: "simulated"}
HDT_ACCURACY_DEG = 1.0  # [deg] what a dual-antenna heading is taken to be good to
GST_MAX_AGE_S = 2.0  # [s] a GST older than this no longer tells the accuracy
NO_HDOP_ACCURACY_M = 99.0  # [m] a fix without HDOP or GST: barely a position


@dataclass
class NmeaReader:
    """NMEA lines in, frames out.

    Attributes:
        bad_checksums: sentences whose checksum did not match.
        unparsed: sentences pynmea2 could not read (or not NMEA at all).
        out_of_range: sentences whose values cannot be (a latitude beyond 90°).
        not_measured: fixes the receiver did not measure (dead reckoning, by hand,
            simulated), not sent.
    """

    bad_checksums: int = 0
    unparsed: int = 0
    out_of_range: int = 0
    not_measured: int = 0
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
            self._accuracy_m = max(lat, lon)
            self._accuracy_at = stamp

    def _gga(self, sentence: Any, stamp: float) -> FixFrame | None:
        try:
            quality = int(getattr(sentence, "gps_qual", 0) or 0)
            latitude = float(sentence.latitude)
            longitude = float(sentence.longitude)
            altitude = float(getattr(sentence, "altitude", 0.0) or 0.0)
            separation = float(getattr(sentence, "geo_sep", 0.0) or 0.0)
            hdop = float(getattr(sentence, "horizontal_dil", "") or "nan")
        except (TypeError, ValueError):
            self.unparsed += 1
            return None
        if quality in NOT_MEASURED:
            self.not_measured += 1
            return None
        accuracy = self._accuracy_m if stamp - self._accuracy_at <= GST_MAX_AGE_S else None
        if accuracy is None:
            per_range = RANGE_ERROR_M.get(quality, UERE_M)
            accuracy = hdop * per_range if math.isfinite(hdop) and hdop > 0 else None
        if accuracy is None:
            accuracy = NO_HDOP_ACCURACY_M
        status = -1 if quality == 0 or not self._valid else NAVSAT_STATUS.get(quality, 0)
        try:
            return FixFrame(
                stamp=stamp,
                latitude=latitude,
                longitude=longitude,
                altitude=altitude + separation,
                horizontal_accuracy=accuracy,
                status=status,
            )
        except ValueError:  # pydantic's ValidationError is one: a latitude of 99°, say
            self.out_of_range += 1
            return None

    def _hdt(self, sentence: Any, stamp: float) -> HeadingFrame | None:
        try:
            heading = float(sentence.heading)
        except (TypeError, ValueError):
            self.unparsed += 1
            return None
        if not math.isfinite(heading):
            self.out_of_range += 1
            return None
        return HeadingFrame(
            stamp=stamp,
            bearing_deg=heading % 360.0,
            accuracy_deg=HDT_ACCURACY_DEG,
            true_north=True,
        )
