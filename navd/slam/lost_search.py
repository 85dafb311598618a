"""Finding a lost robot on its map again, without help.

The mapper calls the robot lost when its scans stop fitting the map where it thinks the robot
is (``ScanMapper.lost``): it was carried somewhere else, its wheels slipped far, a wrong
match put it off. ``LostSearch`` then looks for it, one search per scan while the robot is
held still, all headings, in windows around the last good pose that grow (``WINDOWS_M``:
the most likely places first) up to the whole map when it is small enough to search at once
(``WHOLE_MAP_MAX_CELLS``); the largest is then searched again and again.

A pose is taken only when two searches in a row find it (the second at the first's pose moved
by the odometry since, within ``CONFIRM_M`` and ``CONFIRM_RAD``): the second searches a larger
window than the first, so a pose that is only the best in a small window (a room's
mirror-image twin near the last good pose, while the robot stands in the other half) is
overruled by the better one the larger window holds. Each pose must fit the map as well as a
loop closure must (``loop_min_score`` on the points that land on mapped ground, at least half
of them there) and stand out from its neighbourhood (no place within ``RIVAL_RADIUS_M``
scores ``MAX_RIVAL_RATIO`` of it: not a pose along a featureless corridor). Two rooms alike
beyond the largest window can still fool it, as they would a person.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam.global_search import relocalize
from navd.slam.matcher import Match, rival_ratio
from navd.slam.occupancy import OccupancyGrid
from navd.slam.settings import MapperSettings

__all__ = ["Found", "LostSearch", "fit_on_map"]

FloatArray = npt.NDArray[np.float64]

WINDOWS_M = (4.0, 8.0, 16.0)  # [m] half-widths of the searches around the last good pose
# A whole-map search holds its field and six bounds on a coarsened grid (``relocalize``:
# at most 56 MB on a map coarsened twice; on a larger map, coarsened four times, about 2.8
# bytes per map cell, 140 MB for 50 million): only on maps up to this many cells
# (fr-clinic's 244 m x 432 m at 5 cm is 40 million); larger ones in the windows.
WHOLE_MAP_MAX_CELLS = 50_000_000
CONFIRM_M, CONFIRM_RAD = 0.15, math.radians(5.0)  # two searches agree this closely
KNOWN_FRACTION, MIN_KNOWN_POINTS = 0.5, 10  # share and count of points on mapped ground
RIVAL_RADIUS_M, RIVAL_EXCLUDE_M, MAX_RIVAL_RATIO = 1.5, 0.3, 0.9


@dataclass(frozen=True, slots=True)
class Found:
    """Where the lost robot was found.

    Attributes:
        pose: its pose in the map.
        fit: mean likelihood under the scan points on mapped ground, in [0, 1].
        searches: searches it took, the confirming one included.
        window_m: [m] half-width of the search that confirmed it (0: the whole map).
    """

    pose: Pose2
    fit: float
    searches: int
    window_m: float


class LostSearch:
    """The search for one lost robot: ``step`` once per scan until it returns a pose.

    Args:
        settings: the mapper's (``loop_min_score``, ``max_range_m``, ``blur_sigma_m``).
        last_good: the robot's last pose that fitted the map (the searches centre on it).
    """

    def __init__(self, settings: MapperSettings, last_good: Pose2) -> None:
        self.settings = settings
        self.last_good = last_good
        self.searches = 0
        self._searched = 0  # searches that ran (a scan with too few points runs none)
        # a pose found by the last search, and the odometry pose when it was found
        self._candidate: tuple[Pose2, Pose2] | None = None

    def step(self, grid: OccupancyGrid, points: FloatArray, odom: Pose2) -> Found | None:
        """Search for the scan ``points`` (robot frame, downsampled) taken at odometry pose
        ``odom``; the robot's pose once two searches in a row agree, else None."""
        if grid.empty or points.shape[0] < MIN_KNOWN_POINTS:
            return None
        self.searches += 1
        window = self._window(grid)
        match = relocalize(
            grid,
            points,
            guess=None if window == 0.0 else self.last_good,
            search_xy_m=window,
            search_yaw_rad=math.pi,
            blur_sigma_m=self.settings.blur_sigma_m,
            reach_m=self.settings.max_range_m,
        )
        fit = fit_on_map(grid, points, match, self.settings)
        candidate, self._candidate = self._candidate, None
        if fit is None:
            return None
        if candidate is not None:
            pose, then = candidate
            moved = pose.compose(then.between(odom)).between(match.pose)
            if math.hypot(moved.x, moved.y) <= CONFIRM_M and abs(moved.yaw) <= CONFIRM_RAD:
                return Found(match.pose, fit, self.searches, window)
        self._candidate = (match.pose, odom)
        return None

    def _window(self, grid: OccupancyGrid) -> float:
        """The next search's half-width [m] around the last good pose (0: the whole map):
        the next larger than the last, the largest again once there."""
        whole = grid.shape[0] * grid.shape[1] <= WHOLE_MAP_MAX_CELLS
        _, half_m = grid.whole()
        windows = [w for w in WINDOWS_M if w < 2 * half_m or not whole]
        if whole:
            windows.append(0.0)
        window = windows[min(self._searched, len(windows) - 1)]
        self._searched += 1
        return window


def fit_on_map(
    grid: OccupancyGrid, points: FloatArray, match: Match, settings: MapperSettings
) -> float | None:
    """The match's fit on mapped ground if it is good and unambiguous enough to take a lost
    robot's pose from, else None."""
    known = grid.known_fraction(match.pose, points)
    if known < KNOWN_FRACTION or known * points.shape[0] < MIN_KNOWN_POINTS:
        return None
    fit = match.score / known
    if fit < settings.loop_min_score:
        return None
    field = grid.likelihood_field(
        match.pose, settings.max_range_m + RIVAL_RADIUS_M, settings.blur_sigma_m
    )
    rival = rival_ratio(
        field, points, match.pose, radius_m=RIVAL_RADIUS_M, exclude_m=RIVAL_EXCLUDE_M
    )
    return fit if rival <= MAX_RIVAL_RATIO else None
