"""Mapping a client's stamps onto the daemon clock.

Sensor programs stamp frames with their own clock (any epoch). The offset between the two
clocks is estimated as the smallest ``arrival - stamp`` seen over a sliding window: the
frame that travelled fastest bounds the offset best, and a mapped stamp is never later than
its arrival. The window lets the estimate follow clock drift and jumps.
"""

from __future__ import annotations

from collections import deque

__all__ = ["StampMapper"]


class StampMapper:
    """Sliding-minimum offset estimator for one client.

    Args:
        window_s: [s] how far back (in arrival time) the minimum looks.
    """

    def __init__(self, window_s: float = 10.0) -> None:
        self.window_s = window_s
        # (arrival, offset) with strictly increasing offsets: the front is the window minimum
        self._candidates: deque[tuple[float, float]] = deque()

    def to_daemon(self, stamp: float | None, arrival_s: float) -> float:
        """[s] the daemon-clock time of a frame stamped ``stamp`` that arrived at ``arrival_s``.

        A frame without a stamp is taken as measured when it arrived.
        """
        if stamp is None:
            return arrival_s
        offset = arrival_s - stamp
        candidates = self._candidates
        while candidates and candidates[-1][1] >= offset:
            candidates.pop()
        candidates.append((arrival_s, offset))
        while candidates[0][0] < arrival_s - self.window_s:
            candidates.popleft()
        # Never after arrival, even by the rounding of stamp + (arrival - stamp).
        return min(stamp + candidates[0][1], arrival_s)
