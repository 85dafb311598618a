"""Loop closure: find where a keyframe lies on the map of an earlier pass over the same place.

After a long loop the robot's estimate can be metres off (fr-clinic: 8-10 m after 400 m of
corridors), so the search window must grow with the path driven since the old pass, and a
wide window in a building of corridors finds many places that look alike. The search:

1. Old keyframes near the current pose are split into passes (runs of consecutive
   keyframes); each pass is searched on its own, in a window that grows with the drift
   possible between the robot and the pass's keyframe nearest it: ``LOOP_DRIFT_PER_M`` of
   the shortest path between the two through the pose graph (loops already closed are short
   cuts), from ``LOOP_MIN_WINDOW_M``, capped by ``loop_search_xy_m``. A pass whose nearest
   keyframe the robot left moments ago (less than ``LOOP_MIN_PATH_M`` of path) has drifted
   too little to correct. That is the nearest keyframe, not the pass's last: in a corridor
   driven out and back, the way out and the way back join at the far end into one pass that
   ends only ``loop_min_gap`` keyframes ago.
2. Coarse: the last few keyframes' scans together (a few metres of travel: a corridor with
   its side doors, not one view of bare walls) are matched onto a coarse map of the pass over
   the whole window, by the multi-level branch and bound of ``global_search`` (exact at
   its cell and angle steps, and cheap however wide the window). The search is given
   ``LOOP_COARSE_MIN_SCORE`` as its floor, so a pass with nothing that good in it (most of
   them) is given up early. The match must be unambiguous over the window and beyond, as
   far as the robot could have drifted by its tracking alone (``LOOP_LOOKALIKE_PER_M`` of
   the path since the pass's nearest keyframe): no translation farther than
   ``LOOP_COARSE_EXCLUDE_M`` may score more than ``LOOP_MAX_RIVAL_RATIO`` of it.
3. Fine: the keyframe's own scan is matched onto the full-resolution map of the pass near the
   coarse pose; it must reach ``loop_min_score`` and be unambiguous within
   ``LOOP_RIVAL_RADIUS_M``.
The result is an edge from the old keyframe nearest the match to the new one, for the pose
graph (robust: a wrong one that slipped through pulls less than a right one).

4. Far: a pass the robot may have drifted from by more than ``loop_search_xy_m`` (the window
   the path asks for is wider than the cap) and that holds nothing above the coarse floor
   within the cap (no look-alike either) is searched again out to ``LOOP_FAR_FACTOR`` times
   the cap, at keyframes whose index is a multiple of ``LOOP_FAR_EVERY_KEYFRAMES``: every
   15th while tracking (the mapper searches for loops at every third keyframe), every 5th
   while lost (at every keyframe). A match found there is held, not used, until a far match
   on the same old pass at least ``LOOP_CONFIRM_GAP`` and at most
   ``LOOP_CONFIRM_KEYFRAMES`` keyframes later is found where the first match and the
   tracking between them put it (within ``LOOP_CONFIRM_XY_M`` and
   ``LOOP_CONFIRM_YAW_RAD``); then both are used, each tying its own new keyframe to the
   old pass (docs/slam.md, "Measured history", says which log asked for it).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2, ScanPoints
from navd.slam.global_search import global_search
from navd.slam.keyframe import Keyframe
from navd.slam.matcher import CorrelativeMatcher, rival_ratio
from navd.slam.occupancy import OccupancyGrid
from navd.slam.pose_graph import Edge, graph_distances
from navd.slam.settings import MapperSettings
from navd.slam.voxel import voxel_downsample

__all__ = ["LoopCandidate", "LoopCloser", "LoopCounts"]

FloatArray = npt.NDArray[np.float64]

# The window grows by this share of the shortest path through the pose graph between the
# robot and the pass's keyframe nearest it ([m] per m). (aces, a corridor driven out and
# back: 2 m apart after 35 m.)
LOOP_DRIFT_PER_M = 0.06
# ... from at least this half-width [m].
LOOP_MIN_WINDOW_M = 2.0
# A coarse match must be unambiguous over a wider disc than the window: as far as the
# robot could have drifted by its tracking alone, this share of the path driven since the
# pass's nearest keyframe ([m] per m, at least the window, capped by ``loop_search_xy_m``).
# Loops closed since narrow the window, not the place a look-alike may lie in. (Intel with
# 3 cm of range noise, seed 3: checked over the window alone, a match 16 degrees off in a
# 2 m window went in, and the map was lost at the end, 0.124 m; checked over this, 0.041 m.)
LOOP_LOOKALIKE_PER_M = 0.03
# A pass whose nearest keyframe is fewer metres of path ago than this is not searched (too
# little drift to correct).
LOOP_MIN_PATH_M = 15.0
# Old keyframes within the window plus this of the current pose make up a pass's map [m].
LOOP_PASS_MARGIN_M = 2.0
# Keyframes this many indices apart still belong to the same pass.
LOOP_PASS_JOIN = 5
# At most this many keyframes of a pass are drawn into its coarse map (evenly spread).
LOOP_COARSE_KEYFRAMES = 60
# The coarse map's cell size, as a multiple of the map's, and its blur [cells].
LOOP_COARSE_FACTOR, LOOP_COARSE_BLUR_CELLS = 2, 1.5
# The coarse search's rotation step [rad] (the fine stage searches between the steps).
LOOP_COARSE_ANGLE_STEP_RAD = math.radians(0.5)
# The coarse query: this many newest keyframes' scans together.
LOOP_QUERY_KEYFRAMES = 10
# Coarse match: at least this score, and no rival beyond LOOP_COARSE_EXCLUDE_M [m] within
# the look-alike radius (above) scoring more than LOOP_MAX_RIVAL_RATIO of it.
LOOP_COARSE_MIN_SCORE = 0.5
LOOP_COARSE_EXCLUDE_M = 0.6
# A coarse query with fewer points than this is not searched (nothing to match).
LOOP_MIN_QUERY_POINTS = 20
# Fine match: within LOOP_FINE_XY_M [m] / LOOP_FINE_YAW_RAD of the coarse pose, on the
# full-resolution map of LOOP_SUBMAP_KEYFRAMES keyframes either side of the nearest old one.
LOOP_FINE_XY_M, LOOP_FINE_YAW_RAD = 0.4, 0.06
LOOP_SUBMAP_KEYFRAMES = 10
# A fine match must be unambiguous: no translation within LOOP_RIVAL_RADIUS_M but beyond
# LOOP_RIVAL_EXCLUDE_M of it may score more than LOOP_MAX_RIVAL_RATIO of its score.
LOOP_RIVAL_RADIUS_M, LOOP_RIVAL_EXCLUDE_M, LOOP_MAX_RIVAL_RATIO = 1.0, 0.3, 0.9
# Far loops (step 4): searched out to this times ``loop_search_xy_m``; confirmed by a second
# far match within this many keyframes that agrees with the first to these [m], [rad].
LOOP_FAR_FACTOR = 1.5
LOOP_CONFIRM_KEYFRAMES = 40
# ... at least this many keyframes after the first (their coarse queries share at most half
# their scans; each fine match is of its own keyframe's scan). Far searches run only at
# keyframes whose index is a multiple of LOOP_FAR_EVERY_KEYFRAMES: each costs about 60 ms
# (fr-clinic; 397 of them, at every keyframe searched, took its replay from 44 s to 69 s).
LOOP_CONFIRM_GAP = LOOP_QUERY_KEYFRAMES // 2
LOOP_FAR_EVERY_KEYFRAMES = LOOP_CONFIRM_GAP
LOOP_CONFIRM_XY_M, LOOP_CONFIRM_YAW_RAD = 0.5, math.radians(2.0)


@dataclass
class LoopCounts:
    """What the loop search did (for the replay summary and diagnostics)."""

    checks: int = 0
    found: int = 0
    ambiguous: int = 0
    far_held: int = 0  # far matches held for a second (step 4)
    far_confirmed: int = 0  # ... and confirmed by one


@dataclass(frozen=True, slots=True)
class LoopCandidate:
    """Keyframe ``new`` lies at ``pose`` on the map of the pass holding keyframe ``old``.

    Attributes:
        old: index of the old keyframe the edge starts at.
        new: index of the new keyframe.
        pose: [m, m, rad] the new keyframe's pose on the old pass's map.
        score: fine match score in [0, 1].
    """

    old: int
    new: int
    pose: Pose2
    score: float


def path_lengths(poses: FloatArray) -> FloatArray:
    """[m] distance driven from the first keyframe to each (N poses -> N values)."""
    steps = np.hypot(np.diff(poses[:, 0]), np.diff(poses[:, 1]))
    out: FloatArray = np.concatenate([[0.0], np.cumsum(steps)])
    return out


def passes(indices: npt.NDArray[np.int64], join: int) -> list[npt.NDArray[np.int64]]:
    """Sorted keyframe indices split into runs whose neighbours are at most ``join`` apart."""
    if indices.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(indices) > join) + 1
    return list(np.split(indices, breaks))


class _Miss(enum.Enum):
    """Why searching an old pass gave no loop closure."""

    BLIND = "the newest scans saw (almost) nothing"
    EMPTY_WINDOW = "nothing in the window scored above the coarse floor"
    AMBIGUOUS = "another place within the look-alike distance fits nearly as well"
    WEAK = "the fine match scored below loop_min_score"


class LoopCloser:
    """Searches old passes for the place a new keyframe shows (see the module docstring)."""

    def __init__(self, settings: MapperSettings) -> None:
        self.counts = LoopCounts()
        # Far matches waiting for a second (step 4), each with its pose relative to its old
        # keyframe (a re-solve of the graph meanwhile moves both alike).
        self.held: list[tuple[LoopCandidate, Pose2]] = []
        self.configure(settings)

    def configure(self, settings: MapperSettings) -> None:
        """Take new settings (max_range_m sets the fine matcher's rotation step)."""
        self.settings = settings
        self.fine = CorrelativeMatcher(
            search_xy_m=LOOP_FINE_XY_M,
            search_yaw_rad=LOOP_FINE_YAW_RAD,
            reach_m=settings.max_range_m / 2,
        )

    def search(
        self, keyframes: list[Keyframe], edges: Sequence[Edge], k: int
    ) -> list[LoopCandidate]:
        """Loop closures for keyframe ``k`` (one per old pass at most).

        Args:
            keyframes: every keyframe so far, ``k`` among them.
            edges: the pose graph's edges so far (the window follows its shortest paths).
            k: the index of the keyframe to find on the old passes.
        """
        s = self.settings
        current = keyframes[k]
        if current.scan is None or k <= s.loop_min_gap:
            return []
        poses = np.array([tuple(f.pose) for f in keyframes[: k + 1]])
        driven = path_lengths(poses)
        old = poses[: k - s.loop_min_gap]
        distance = np.hypot(old[:, 0] - current.pose.x, old[:, 1] - current.pose.y)
        # Only the old map is searched: keyframes that were not matched are left out.
        mapped = np.array([f.mapped for f in keyframes[: old.shape[0]]], dtype=np.bool_)
        distance[~mapped] = np.inf
        if distance.min() > s.loop_search_radius_m:
            return []
        near = np.flatnonzero(distance <= s.loop_search_xy_m + LOOP_PASS_MARGIN_M)
        found = []
        linked: FloatArray | None = None  # [m] through the graph, once a pass needs it
        for run in passes(near, LOOP_PASS_JOIN):
            # The drift to correct is from the part of the pass nearest the robot's (drifted)
            # estimate, not from where the pass ended: a robot that stayed near for a long pass
            # (aces: 414-977 s) comes back to its old part (613 s) 3-4 m off.
            nearest = run[np.argmin(distance[run])]
            since_nearest_m = float(driven[k] - driven[nearest])
            if since_nearest_m < LOOP_MIN_PATH_M or distance[nearest] > s.loop_search_radius_m:
                continue
            if linked is None:
                linked = graph_distances(edges, k + 1, k)
            wanted = max(LOOP_MIN_WINDOW_M, LOOP_DRIFT_PER_M * float(linked[nearest]))
            window = min(s.loop_search_xy_m, wanted)
            alike = max(window, min(s.loop_search_xy_m, LOOP_LOOKALIKE_PER_M * since_nearest_m))
            result = self._search_pass(keyframes, k, run, window, alike)
            if isinstance(result, LoopCandidate):
                found.append(result)
            elif (
                result is _Miss.EMPTY_WINDOW  # a look-alike or a blind query is not widened
                and wanted > s.loop_search_xy_m
                and k % LOOP_FAR_EVERY_KEYFRAMES == 0
            ):
                far_cap = LOOP_FAR_FACTOR * s.loop_search_xy_m
                far_window = min(far_cap, wanted)
                far_alike = max(far_window, min(far_cap, LOOP_LOOKALIKE_PER_M * since_nearest_m))
                far = self._search_pass(keyframes, k, run, far_window, far_alike)
                if isinstance(far, LoopCandidate):
                    found.extend(self._confirmed(keyframes, far))
        return found

    def _confirmed(self, keyframes: list[Keyframe], far: LoopCandidate) -> list[LoopCandidate]:
        """The far match ``far`` and the held one it confirms, if it confirms one (step 4 of
        the module docstring); otherwise nothing, and ``far`` is held in turn."""
        k = far.new
        self.held = [h for h in self.held if 0 <= k - h[0].new <= LOOP_CONFIRM_KEYFRAMES]
        for entry in self.held:
            held, on_old = entry
            if k - held.new < LOOP_CONFIRM_GAP:
                continue
            # On the same old pass: its keyframes passed at about the pace of the new ones
            # (twice it, and a submap's reach either way, allowed).
            if abs(far.old - held.old) > 2 * (k - held.new) + LOOP_SUBMAP_KEYFRAMES:
                continue
            # Where the held match and the tracking since put keyframe k on the old map.
            then = keyframes[held.old].pose.compose(on_old)  # held.pose, as the graph is now
            predicted = then.compose(keyframes[held.new].pose.between(keyframes[k].pose))
            off = predicted.between(far.pose)
            if math.hypot(off.x, off.y) <= LOOP_CONFIRM_XY_M and abs(off.yaw) <= (
                LOOP_CONFIRM_YAW_RAD
            ):
                self.held.remove(entry)
                self.counts.far_confirmed += 1
                return [LoopCandidate(held.old, held.new, then, held.score), far]
        self.held.append((far, keyframes[far.old].pose.between(far.pose)))
        self.counts.far_held += 1
        return []

    def _search_pass(
        self,
        keyframes: list[Keyframe],
        k: int,
        run: npt.NDArray[np.int64],
        window_m: float,
        alike_m: float,
    ) -> LoopCandidate | _Miss:
        """The pass ``run``'s loop closure for keyframe ``k``, searched within ``window_m``,
        unambiguous within ``alike_m`` [m, half-widths], or why there is none."""
        s = self.settings
        self.counts.checks += 1
        current = keyframes[k]
        assert current.scan is not None
        coarse = self._coarse_match(keyframes, k, run, window_m, alike_m)
        if isinstance(coarse, _Miss):
            if coarse is _Miss.AMBIGUOUS:
                self.counts.ambiguous += 1
            return coarse
        # The fine map: the old keyframes around the one nearest the coarse pose.
        xy = np.array([(keyframes[i].pose.x, keyframes[i].pose.y) for i in run])
        j = int(run[np.argmin(np.hypot(xy[:, 0] - coarse.x, xy[:, 1] - coarse.y))])
        submap = OccupancyGrid(s.resolution_m)
        end = min(j + LOOP_SUBMAP_KEYFRAMES + 1, k - s.loop_min_gap)
        for frame in keyframes[max(0, j - LOOP_SUBMAP_KEYFRAMES) : end]:
            if frame.scan is not None and frame.mapped:
                submap.insert(frame.pose, frame.scan)
        field = submap.likelihood_field(coarse, s.max_range_m + LOOP_FINE_XY_M, s.blur_sigma_m)
        points = voxel_downsample(current.scan.hits, s.voxel_size_m)
        match = self.fine.match(field, points, coarse)
        if match.score < s.loop_min_score:
            return _Miss.WEAK
        rival = rival_ratio(
            field, points, match.pose, radius_m=LOOP_RIVAL_RADIUS_M, exclude_m=LOOP_RIVAL_EXCLUDE_M
        )
        if rival > LOOP_MAX_RIVAL_RATIO:
            self.counts.ambiguous += 1
            return _Miss.AMBIGUOUS
        self.counts.found += 1
        return LoopCandidate(j, k, match.pose, match.score)

    def _coarse_match(
        self,
        keyframes: list[Keyframe],
        k: int,
        run: npt.NDArray[np.int64],
        window_m: float,
        alike_m: float,
    ) -> Pose2 | _Miss:
        """Where the newest keyframes' scans fit the pass's coarse map within the window,
        if no other place within ``alike_m`` fits nearly as well; else why not."""
        s = self.settings
        current = keyframes[k]
        resolution = s.resolution_m * LOOP_COARSE_FACTOR
        grid = OccupancyGrid(resolution)
        step = max(1, math.ceil(run.size / LOOP_COARSE_KEYFRAMES))
        for i in run[::step]:
            frame = keyframes[int(i)]
            if frame.scan is not None:
                grid.insert(frame.pose, frame.scan)
        field = grid.likelihood_field(
            current.pose, s.max_range_m + alike_m, resolution * LOOP_COARSE_BLUR_CELLS
        )
        query = _query_points(keyframes, k, resolution)
        if query.shape[0] < LOOP_MIN_QUERY_POINTS:
            return _Miss.BLIND  # a wide hall, a short lidar
        pose, score, _ = global_search(
            field,
            query,
            center=current.pose,
            half_width_m=window_m,
            yaw_window_rad=s.loop_search_yaw_rad,
            angle_step_rad=LOOP_COARSE_ANGLE_STEP_RAD,
            min_score=LOOP_COARSE_MIN_SCORE,  # most passes hold no match: given up early
        )
        if score < LOOP_COARSE_MIN_SCORE:
            return _Miss.EMPTY_WINDOW
        rival = rival_ratio(field, query, pose, radius_m=alike_m, exclude_m=LOOP_COARSE_EXCLUDE_M)
        if rival > LOOP_MAX_RIVAL_RATIO:
            return _Miss.AMBIGUOUS
        return pose


def _query_points(keyframes: list[Keyframe], k: int, voxel_m: float) -> FloatArray:
    """The scans of the newest LOOP_QUERY_KEYFRAMES keyframes up to ``k``, in ``k``'s frame."""
    current = keyframes[k].pose
    clouds = []
    for frame in keyframes[max(0, k - LOOP_QUERY_KEYFRAMES + 1) : k + 1]:
        scan: ScanPoints | None = frame.scan
        if scan is not None and scan.hits.size:
            clouds.append(current.between(frame.pose).transform(scan.hits))
    if not clouds:
        return np.zeros((0, 2))
    return voxel_downsample(np.vstack(clouds), voxel_m)
