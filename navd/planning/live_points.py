"""The live obstacle points the local planner steers by, in the map frame: each source's
latest hits (every lidar's, every range sensor's and depth camera's), those within
``LIVE_SCAN_S`` of the newest, and the fleet's other robots, each a disc where it is and
where it will be ``ROBOT_AHEAD_S`` on. And what the live lidars' rays covered, so that
remembered obstacles are used only where no lidar looks now.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.geometry import ALL_AROUND, FieldOfView

__all__ = ["LIVE_SCAN_S", "ROBOT_AHEAD_S", "LivePoints"]

FloatArray = npt.NDArray[np.float64]

# [s] another source's latest scan joins the live obstacle points while it is this much older
# than the newest at most (two lidars at 5-10 Hz; a silent one leaves no ghosts behind).
LIVE_SCAN_S = 0.5
# [s] another robot of the fleet is kept out of where it will be this far ahead too.
ROBOT_AHEAD_S = 1.0
# [m] spacing of the points that outline another robot's disc.
ROBOT_OUTLINE_M = 0.05


class LivePoints:
    """Every source's latest hits, and the other robots' outlines.

    Attributes:
        points: [m] all of them together (N x 2).
        robot_points: [m] the other robots' outlines alone.
        views: what the live lidars' rays covered (all around when none is live).
    """

    def __init__(self) -> None:
        # by source: (stamp [s], hits [m], what a lidar's rays covered; None for another
        # sensor's, which says nothing of where a lidar looks)
        self._latest: dict[str, tuple[float, FloatArray, FieldOfView | None]] = {}
        self.points: FloatArray = np.empty((0, 2))
        self.robot_points: FloatArray = np.empty((0, 2))
        self.views: tuple[FieldOfView, ...] = (ALL_AROUND,)

    def add(self, source: str, stamp: float, hits_m: FloatArray, view: FieldOfView | None) -> None:
        """Take ``source``'s latest hits [m, map frame] at ``stamp`` [s]; ``view`` what a
        lidar's rays covered (None for other sensors)."""
        latest = self._latest
        latest[source] = (stamp, hits_m, view)
        for old in [s for s, (t, _, _) in latest.items() if t < stamp - LIVE_SCAN_S]:
            del latest[old]
        self.views = tuple(v for _, _, v in latest.values() if v is not None) or (ALL_AROUND,)
        self._join()

    def set_robots(self, robots: tuple[tuple[str, float, float, float, float, float], ...]) -> None:
        """The fleet's other robots (name, x, y, yaw, forward speed, radius [m, rad, m/s]),
        until the next call."""
        outlines = [np.empty((0, 2))]
        for _, x, y, yaw, speed, radius in robots:
            ahead = (
                x + speed * ROBOT_AHEAD_S * math.cos(yaw),
                y + speed * ROBOT_AHEAD_S * math.sin(yaw),
            )
            for cx, cy in ((x, y), ahead):
                n = max(math.ceil(2.0 * math.pi * radius / ROBOT_OUTLINE_M), 8)
                a = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
                ring = np.column_stack([cx + radius * np.cos(a), cy + radius * np.sin(a)])
                outlines += [ring, np.array([[cx, cy]])]
        self.robot_points = np.concatenate(outlines)
        self._join()

    def _join(self) -> None:
        parts = [h for _, h, _ in self._latest.values()]
        if self.robot_points.shape[0]:
            parts.append(self.robot_points)
        if not parts:
            self.points = np.empty((0, 2))
        else:
            self.points = parts[0] if len(parts) == 1 else np.concatenate(parts)
