"""Asking an RPLIDAR for its scan modes: GET_LIDAR_CONF one key at a time (the number of
modes, the typical one, then each mode's name, longest range, time per sample and answer
type), and the modes they describe, the typical one first; and which of them to run."""

from __future__ import annotations

import struct

from navd.sensors.rplidar_protocol import Conf, ScanModeInfo, conf_request

__all__ = ["ModeQuery", "choose_mode"]

_PER_MODE = (Conf.MODE_NAME, Conf.MAX_DISTANCE, Conf.US_PER_SAMPLE, Conf.ANSWER_TYPE)


class ModeQuery:
    """One round of questions; ``next_request`` gives each in turn, ``answer`` takes each
    answer's body (the key echoed, then the value)."""

    def __init__(self) -> None:
        self._queue: list[tuple[Conf, int | None]] = [
            (Conf.MODE_COUNT, None),
            (Conf.TYPICAL_MODE, None),
        ]
        self._asking: tuple[Conf, int | None] | None = None
        self._values: dict[tuple[Conf, int | None], bytes] = {}

    @property
    def asking(self) -> str:
        """The question out, for the log."""
        if self._asking is None:
            return ""
        key, mode = self._asking
        return f"GET_LIDAR_CONF 0x{key:02X}" + ("" if mode is None else f" of mode {mode}")

    def next_request(self) -> bytes | None:
        """The next question's bytes, or None when every answer is in."""
        if not self._queue:
            self._asking = None
            return None
        self._asking = self._queue.pop(0)
        return conf_request(*self._asking)

    def answer(self, body: bytes) -> bool:
        """Take an answer; False when it is not the answer to the question out."""
        if self._asking is None or len(body) < 4:
            return False
        if struct.unpack_from("<I", body)[0] != self._asking[0]:
            return False
        self._values[self._asking] = body[4:]
        if self._asking == (Conf.MODE_COUNT, None):
            count = struct.unpack_from("<H", body, 4)[0] if len(body) >= 6 else 0
            self._queue += [(key, mode) for mode in range(count) for key in _PER_MODE]
        return True

    def modes(self) -> list[ScanModeInfo]:
        """The modes described, the typical one first."""
        values = self._values
        count = struct.unpack_from("<H", values.get((Conf.MODE_COUNT, None), b"\0\0"))[0]
        modes = []
        for mode in range(count):
            name = values[(Conf.MODE_NAME, mode)].split(b"\0", 1)[0]
            modes.append(
                ScanModeInfo(
                    mode,
                    name.decode("ascii", "replace"),
                    struct.unpack_from("<I", values[(Conf.MAX_DISTANCE, mode)])[0] / 256.0,
                    struct.unpack_from("<I", values[(Conf.US_PER_SAMPLE, mode)])[0] / 256.0,
                    values[(Conf.ANSWER_TYPE, mode)][0],
                )
            )
        typical = values.get((Conf.TYPICAL_MODE, None))
        if typical is not None and len(typical) >= 2:
            first = struct.unpack_from("<H", typical)[0]
            modes.sort(key=lambda m: m.mode_id != first)
        return modes


def choose_mode(modes: list[ScanModeInfo], wanted: str | None) -> ScanModeInfo | None:
    """The mode named ``wanted`` (any case), else the typical one (first) when navd reads
    its samples, else the readable one with the most samples a second; None when the one
    named is not readable or not there, or none is readable."""
    if wanted is not None:
        named = [m for m in modes if m.name.lower() == wanted.lower()]
        return named[0] if named and named[0].readable else None
    readable = [m for m in modes if m.readable]
    if not readable:
        return None
    if modes[0].readable:
        return modes[0]
    return min(readable, key=lambda m: m.us_per_sample)
