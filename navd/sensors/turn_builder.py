"""A turning lidar's points, in the order measured, grouped into turns: each turn becomes
one scan (``revolution_scan``) the moment it is complete.

A turn ends where the clockwise angle passes the front once more, counted on the angle
followed continuously (each step taken the short way round), with the next turn's end a full
turn further on: the express scan's per-sample corrections step a little backwards and
forwards across the front, and that is one turn's end, not several. The device may also say
where a turn begins (``end_turn``; the standard scan's start flag). The first turn after a
start is partial and is sent like any other; what a consumer needs is every ray's time.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.sensors.revolution_scan import turn_scan
from navd.wire import ScanFrame

__all__ = ["MIN_BINS", "TurnBuilder"]

MIN_BINS = 720  # 0.5 deg: finer than the spacing of any of these lidars at 10 Hz

FloatArray = npt.NDArray[np.float64]


class TurnBuilder:
    """Collects one turn at a time.

    Args:
        range_min_m, range_max_m: [m] the lidar's valid interval (``range_max_m`` may be
            set later, once the lidar has said it).
    """

    def __init__(self, range_min_m: float, range_max_m: float) -> None:
        self.range_min_m = range_min_m
        self.range_max_m = range_max_m
        self._angles: list[float] = []
        self._ranges: list[float] = []
        self._intensities: list[float] = []
        self._times: list[float] = []
        self._point_s = 0.0  # [s] between two points, last seen
        self._last_deg = math.nan  # the last point's angle as measured [deg]
        self._unwrapped_deg = 0.0  # ... followed continuously since the start
        self._turn_ends_at = math.nan  # [deg, continuous] where the turn collected ends

    def add(
        self,
        angles_cw_deg: FloatArray,
        ranges_m: FloatArray,
        times_s: FloatArray,
        intensities: FloatArray | None = None,
    ) -> list[ScanFrame]:
        """Points in the order measured ([deg] clockwise, [m] with NaN for no return, [s]
        on this computer's clock, intensities or None); the turns they completed."""
        if len(times_s) > 1:
            self._point_s = float(times_s[-1] - times_s[-2])
        angles = np.asarray(angles_cw_deg, dtype=np.float64)
        first = angles[0] if math.isnan(self._last_deg) else self._last_deg
        steps = np.diff(np.concatenate(([first], angles)))
        unwrapped = self._unwrapped_deg + np.cumsum((steps + 180.0) % 360.0 - 180.0)
        if math.isnan(self._last_deg):
            unwrapped += angles[0]
        self._last_deg = float(angles[-1])
        self._unwrapped_deg = float(unwrapped[-1])
        if math.isnan(self._turn_ends_at):
            self._turn_ends_at = 360.0 * (math.floor(unwrapped[0] / 360.0) + 1.0)
        scans: list[ScanFrame] = []
        begin = 0
        while True:
            past = np.flatnonzero(unwrapped[begin:] >= self._turn_ends_at)
            split = begin + int(past[0]) if past.size else len(angles)
            part = slice(begin, split)
            self._extend(
                angles[part],
                ranges_m[part],
                times_s[part],
                None if intensities is None else intensities[part],
            )
            if split == len(angles):
                return scans
            scan = self.end_turn()
            if scan is not None:
                scans.append(scan)
            self._turn_ends_at = 360.0 * (round(unwrapped[split] / 360.0) + 1.0)
            begin = split

    def end_turn(self) -> ScanFrame | None:
        """Close the turn collected so far: its scan, or None when it holds no return."""
        if not math.isnan(self._last_deg):  # the next point begins a turn
            self._turn_ends_at = 360.0 * (round(self._unwrapped_deg / 360.0) + 1.0)
        if not self._angles:
            return None
        count = len(self._angles)
        bins = max(MIN_BINS, 360 * math.ceil(count / 360))
        has_intensity = not all(math.isnan(v) for v in self._intensities)
        scan = turn_scan(
            np.array(self._angles),
            np.array(self._ranges),
            intensities=np.array(self._intensities) if has_intensity else None,
            stamp=self._times[0],
            duration_s=self._times[-1] - self._times[0] + self._point_s,
            bins=bins,
            range_min_m=self.range_min_m,
            range_max_m=self.range_max_m,
        )
        self._drop_points()
        return scan

    def clear(self) -> None:
        """Forget the turn collected so far (the device started over): the next point
        begins a turn that ends at the front."""
        self._drop_points()
        self._last_deg = math.nan
        self._turn_ends_at = math.nan

    def _drop_points(self) -> None:
        self._angles.clear()
        self._ranges.clear()
        self._intensities.clear()
        self._times.clear()

    def _extend(
        self,
        angles: FloatArray,
        ranges: FloatArray,
        times: FloatArray,
        intensities: FloatArray | None,
    ) -> None:
        self._angles.extend(angles.tolist())
        self._ranges.extend(ranges.tolist())
        self._times.extend(times.tolist())
        if intensities is None:
            self._intensities.extend([math.nan] * len(angles))
        else:
            self._intensities.extend(intensities.tolist())
