"""Following a planned route: where the robot is along it, what lies ahead, what blocks it."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.planning._distance_kernels import any_within, nearest_on_polyline
from navd.planning.dwa import PathField, path_field

__all__ = ["Route"]

FloatArray = npt.NDArray[np.float64]

# Stations along the route are checked for obstacles this far apart [m].
STATION_STEP_M = 0.1


class Route:
    """A polyline the robot follows; progress along it only moves forward.

    Args:
        points_m: [m] N x 2 map points, from the robot to the goal.
    """

    def __init__(self, points_m: FloatArray) -> None:
        self.points_m = np.require(points_m, np.float64, ("C", "W"))  # one kernel type
        self.field: PathField = path_field(points_m)
        steps = np.hypot(*np.diff(points_m, axis=0).T) if len(points_m) > 1 else np.empty(0)
        self.cumulative: FloatArray = np.concatenate([[0.0], np.cumsum(steps)])
        self.progress = 0
        # A control step asks where the robot is several times (remaining distance, carrot,
        # stuck watch, straying) and whether the route is blocked at twice the scan rate:
        # the last answers are kept while their inputs stand.
        self._located: tuple[Pose2, int, tuple[int, float, float]] | None = None
        self._blocked: tuple[int, FloatArray, float, float, bool] | None = None

    @property
    def length_m(self) -> float:
        """[m] the whole route's length."""
        return float(self.cumulative[-1])

    def locate(self, pose: Pose2) -> tuple[int, float, float]:
        """(segment, fraction along it, distance [m]) of the route point nearest the robot,
        searched from the last progress on (so a route that doubles back is not cut short)."""
        points = self.points_m
        if points.shape[0] == 1:
            return 0, 0.0, float(math.hypot(points[0, 0] - pose.x, points[0, 1] - pose.y))
        last = self._located
        if last is not None and last[1] == self.progress and last[0] == pose:
            return last[2]
        segment, t, d = nearest_on_polyline(points, self.progress, float(pose.x), float(pose.y))
        self.progress = segment
        found = (segment, t, d)
        self._located = (pose, self.progress, found)
        return found

    def _station(self, segment: int, fraction: float) -> float:
        """[m] distance along the route of a point on ``segment``."""
        if self.cumulative.size < 2:
            return 0.0
        start = self.cumulative[segment]
        return float(start + fraction * (self.cumulative[segment + 1] - start))

    def station(self, pose: Pose2) -> float:
        """[m] how far along the route the robot's nearest route point is."""
        return self._station(*self.locate(pose)[:2])

    def distance_to(self, pose: Pose2) -> float:
        """[m] from the robot to the route."""
        return self.locate(pose)[2]

    def remaining(self, pose: Pose2) -> float:
        """[m] from the robot to the route, then along it to the goal."""
        segment, fraction, distance = self.locate(pose)
        return distance + self.length_m - self._station(segment, fraction)

    def point_at(self, station_m: FloatArray) -> FloatArray:
        """[m] K x 2 route points at distances ``station_m`` along it (clamped to its ends)."""
        return np.column_stack(
            [
                np.interp(station_m, self.cumulative, self.points_m[:, 0]),
                np.interp(station_m, self.cumulative, self.points_m[:, 1]),
            ]
        )

    def carrot(self, pose: Pose2, lookahead_m: float) -> tuple[float, float]:
        """[m] the route point ``lookahead_m`` ahead of the robot's nearest route point."""
        here = self._station(*self.locate(pose)[:2])
        x, y = self.point_at(np.array([min(here + lookahead_m, self.length_m)]))[0]
        return float(x), float(y)

    def blocked(self, obstacles_m: FloatArray, radius_m: float, ahead_m: float) -> bool:
        """True if an obstacle point lies within ``radius_m`` of the next ``ahead_m`` of route."""
        if obstacles_m.shape[0] == 0:
            return False
        last = self._blocked
        if (
            last is not None
            and last[0] == self.progress
            and last[1] is obstacles_m  # the same scan's points (a new scan: a new array)
            and last[2:4] == (radius_m, ahead_m)
        ):
            return last[4]
        here = self.cumulative[self.progress]
        stations = np.arange(here, min(here + ahead_m, self.length_m), STATION_STEP_M)
        blocked = stations.size > 0 and any_within(
            np.ascontiguousarray(self.point_at(stations), dtype=np.float64),
            np.ascontiguousarray(obstacles_m, dtype=np.float64),
            float(radius_m),
        )
        self._blocked = (self.progress, obstacles_m, radius_m, ahead_m, blocked)
        return blocked
