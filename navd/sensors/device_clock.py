"""A device's own clock read on this computer's: a lidar that stamps its packets with a
counter (the LD06's milliseconds, wrapping at 30 s) is placed in time by its packets, not by
when a busy program happened to read them.

Each packet gives one sample of the offset between the two clocks: when it arrived here
(less the time its bytes took on the line) minus the device's reading. Every delay on the
way (the adapter, the kernel, the program scheduled late) makes that sample larger, never
smaller, so the smallest sample of the last ``WINDOW_S`` of the device's time is the offset:
one packet in two seconds that came through promptly is enough, and a program that stalled
and reads a backlog still has the samples from before it. A window, not all time, so drift
between the crystals (100 ppm: 0.1 ms a second) never accumulates. A sample much smaller
than the offset, or larger by half a wrap, means the device's clock jumped (it restarted, or
was silent past a wrap): the estimate starts afresh. A sample larger by less is a delay and
changes nothing.

The smallest sample still steps when the one that set it leaves the window, or a prompter
one comes: on a busy machine by several milliseconds. The offset in force follows it at no
more than ``SLEW`` (after the first ``WINDOW_S`` of a start, where it follows at once), so
the time between two of the device's readings stays the device's: a turn of a lidar keeps
its duration (a 6 ms step inside a 100 ms turn made it 6 % short), as the crystals, 100 ppm
apart, would have it.
"""

from __future__ import annotations

import collections
import math

__all__ = ["JUMP_S", "SLEW", "WINDOW_S", "DeviceClock"]

WINDOW_S = 2.0  # [s] the offset is the smallest sample this recent
JUMP_S = 0.5  # [s] a sample this much below the offset in force: the device clock jumped
SLEW = 0.01  # [s/s] the fastest the offset in force moves, per second of the device's time


class DeviceClock:
    """Maps a wrapping device counter to this computer's clock.

    Args:
        wrap_s: [s] the counter's period (the LD06: 30 s).
    """

    def __init__(self, wrap_s: float) -> None:
        self.wrap_s = wrap_s
        self._last_raw: float | None = None
        self._unwrapped = 0.0
        self._samples: collections.deque[tuple[float, float]] = collections.deque()
        self.jumps = 0  # times the estimate started afresh
        self._start = 0.0  # [s, device, unwrapped] when the estimate last started
        self._applied = math.nan  # [s] the offset in force
        self._applied_at = 0.0  # [s, device, unwrapped] when it was last moved

    def host_time(self, device_s: float, sent_s: float) -> float:
        """[s, this computer's clock] of the device reading ``device_s`` [s, 0 to wrap),
        given ``sent_s``: when the packet carrying it began arriving here at the latest (its
        arrival less its time on the line)."""
        if self._last_raw is not None:
            self._unwrapped += (device_s - self._last_raw) % self.wrap_s
        else:
            self._unwrapped = device_s
        self._last_raw = device_s
        sample = sent_s - self._unwrapped
        samples = self._samples
        change = sample - self._offset() if samples else 0.0
        if change < -JUMP_S or change > self.wrap_s / 2:
            self.jumps += 1
            samples.clear()
            self._unwrapped = device_s
            sample = sent_s - device_s
        if not samples:
            self._start = self._unwrapped
        while samples and samples[-1][1] >= sample:
            samples.pop()  # a later sample no larger makes it useless: keep a rising deque
        samples.append((self._unwrapped, sample))
        while samples[0][0] < self._unwrapped - WINDOW_S:  # on the device's time: a
            samples.popleft()  # program that stalled reads late, the window holds
        return self._unwrapped + self._in_force()

    def _in_force(self) -> float:
        """The offset in force: the smallest sample, followed at no more than SLEW once the
        start's first WINDOW_S has passed."""
        target = self._offset()
        now = self._unwrapped
        if math.isnan(self._applied) or now - self._start < WINDOW_S:
            self._applied = target
        else:
            most = SLEW * max(now - self._applied_at, 0.0)
            self._applied += min(max(target - self._applied, -most), most)
        self._applied_at = now
        return self._applied

    def _offset(self) -> float:
        return self._samples[0][1] if self._samples else math.nan
