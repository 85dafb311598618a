"""One scan from several lidars: each lidar's latest sweep, gathered into one robot-frame scan.

SLAM adds a scan to the map only when it makes a keyframe, so two lidars fed in turn would
map mostly the one whose sweep happens to come first after each keyframe distance. Their
sweeps are gathered instead: once every lidar has sent one, the set is one scan at the
newest sweep's time, the older sweeps moved by the robot's wheel-odometry motion since
their own time. A lidar coming round again before the others (one gone quiet) releases the
set as it is, so SLAM never waits for a silent lidar.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass

import numpy as np

from navd.geometry import ALL_AROUND, Pose2, ScanPoints

__all__ = ["AssembledScan", "ScanAssembler"]


@dataclass(frozen=True, slots=True)
class AssembledScan:
    """Sweeps of one round as one scan.

    Attributes:
        stamp: [s] the newest sweep's time, which the points are at.
        points: the sweeps' points in the robot frame at ``stamp``.
        odom: the wheel-odometry pose at ``stamp`` (None without wheel odometry).
        lidars: how many lidars' sweeps it holds.
    """

    stamp: float
    points: ScanPoints
    odom: Pose2 | None
    lidars: int


class ScanAssembler:
    """Gathers a sweep of each lidar in ``lidars`` into one scan (see the module docstring).

    Args:
        lidars: the device ids of the lidars on the robot.
    """

    def __init__(self, lidars: Collection[str]) -> None:
        self.lidars = frozenset(lidars)
        self._round: dict[str, tuple[float, ScanPoints, Pose2 | None]] = {}
        self.partial = 0  # rounds released without every lidar

    def add(
        self, lidar: str, stamp: float, points: ScanPoints, odom: Pose2 | None
    ) -> AssembledScan | None:
        """Take one lidar's sweep (robot frame, wheel-odometry pose at its time); the
        gathered scan when this completes a round, or when it starts the next one first."""
        released = None
        if lidar in self._round:  # round again before the others: go with what there is
            released = self._release()
            self.partial += 1
        self._round[lidar] = (stamp, points, odom)
        if self._round.keys() >= self.lidars:
            released = self._release()
        return released

    def _release(self) -> AssembledScan:
        parts = sorted(self._round.values(), key=lambda part: part[0])
        self._round = {}
        stamp, _, odom = parts[-1]
        hits, misses = [], []
        for _, points, at in parts:
            if odom is not None and at is not None and at != odom:
                moved = odom.between(at)  # the sweep's pose seen from the newest one's
                hits.append(moved.transform(points.hits))
                misses.append(moved.transform(points.misses))
            else:
                hits.append(points.hits)
                misses.append(points.misses)
        covered = sum(min(points.view.span_rad, 2.0 * math.pi) for _, points, _ in parts)
        view = ALL_AROUND if covered >= 2.0 * math.pi - 1e-6 else parts[-1][1].view
        merged = ScanPoints(np.concatenate(hits), np.concatenate(misses), view)
        return AssembledScan(stamp, merged, odom, len(parts))
