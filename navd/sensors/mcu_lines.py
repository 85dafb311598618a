"""A microcontroller's lines: the bumpers, cliff sensors, range sensors and battery that an
Arduino, an STM32 or any MCU reads, sent as text lines on a serial port (``navd sensor mcu``).

One reading a line, words apart, ``#`` starting a comment::

    bumper NAME 0|1                  a bumper, 1 while pressed
    cliff NAME 0|1                   a cliff sensor, 1 while the floor is gone
    range NAME METRES [FOV_DEG [MAX_M [MIN_M]]]
                                     a range sensor; "inf" or "-": nothing within reach
    battery VOLTS [AMPS [PERCENT [charging|discharging]]]
                                     AMPS negative while discharging, PERCENT 0-100

NAME is the sensor's mount in navd's config (``[mounts.contacts.NAME]``,
``[mounts.ranges.NAME]``). A range sensor's cone defaults to ``DEFAULT_FOV_DEG`` and
``DEFAULT_MAX_M`` (an HC-SR04's). Send each bumper's and cliff sensor's state at least every
0.25 s (navd holds the robot when a contact sensor falls silent for ``tcp.contact_timeout_s``,
0.5 s): the program never repeats a state the MCU did not send. A line that is none of these,
or whose values cannot be, is counted and skipped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import serial

from navd.wire import BatteryFrame, ContactFrame, RangeFrame, SensorFrame

__all__ = ["DEFAULT_FOV_DEG", "DEFAULT_MAX_M", "McuLines"]

DEFAULT_FOV_DEG = 15.0  # an HC-SR04's cone
DEFAULT_MAX_M = 4.0
DEFAULT_MIN_M = 0.02
MAX_LINE_BYTES = 256
_CHARGING = {"charging": True, "discharging": False}


@dataclass
class McuLines:
    """MCU lines in, frames out.

    Attributes:
        unparsed: lines that were none of the readings.
        out_of_range: readings whose values cannot be.
    """

    unparsed: int = 0
    out_of_range: int = 0
    _pending: bytearray = field(default_factory=bytearray)

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        """Take bytes read at ``stamp`` [s]; the frames of the whole lines among them."""
        self._pending.extend(data)
        frames: list[SensorFrame] = []
        while (end := self._pending.find(b"\n")) >= 0:
            line = bytes(self._pending[:end]).decode("ascii", errors="replace")
            del self._pending[: end + 1]
            frame = self.line(line, stamp)
            if frame is not None:
                frames.append(frame)
        if len(self._pending) > MAX_LINE_BYTES:  # no line end in sight
            self.unparsed += 1
            self._pending.clear()
        return frames

    def line(self, text: str, stamp: float) -> SensorFrame | None:
        """One line read at ``stamp`` [s]: its frame, if it is a reading."""
        words = text.split("#", 1)[0].split()
        if not words:
            return None
        try:
            return self._reading(words, stamp)
        except (IndexError, KeyError):
            self.unparsed += 1
        except ValueError:  # a number that is not one, or a value pydantic refused
            self.out_of_range += 1
        return None

    def _reading(self, words: list[str], stamp: float) -> SensorFrame:
        kind = words[0].lower()
        if kind in {"bumper", "cliff"}:
            state = {"0": False, "1": True}[words[2]]
            contact: Literal["bumper", "cliff"] = "bumper" if kind == "bumper" else "cliff"
            return ContactFrame(stamp=stamp, sensor=words[1], kind=contact, triggered=state)
        if kind == "range":
            fov = float(words[3]) if len(words) > 3 else DEFAULT_FOV_DEG
            max_m = float(words[4]) if len(words) > 4 else DEFAULT_MAX_M
            min_m = float(words[5]) if len(words) > 5 else DEFAULT_MIN_M
            value = None if words[2] in ("inf", "-") else float(words[2])
            if value is not None and (not math.isfinite(value) or value > max_m):
                value = None
            return RangeFrame(
                stamp=stamp,
                sensor=words[1],
                range=value,
                field_of_view=math.radians(fov),
                max_range=max_m,
                min_range=min_m,
            )
        if kind == "battery":
            percent = float(words[3]) / 100.0 if len(words) > 3 else None
            charging = (
                {"charging": True, "discharging": False}[words[4]] if len(words) > 4 else None
            )
            return BatteryFrame(
                stamp=stamp,
                voltage=float(words[1]),
                current=float(words[2]) if len(words) > 2 else None,
                percentage=percent,
                charging=charging,
            )
        raise KeyError(kind)

    def counts(self) -> dict[str, int]:
        return {"unparsed": self.unparsed, "out_of_range": self.out_of_range}

    def opened(self, device: serial.Serial) -> None:
        """Nothing to start: the MCU sends by itself."""

    def silent(self) -> None:
        """Nothing to ask again."""

    def closing(self, device: serial.Serial) -> None:
        """Nothing to stop."""

    def tick(self, now: float) -> None:
        """Nothing waits on the clock."""
