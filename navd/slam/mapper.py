"""Scan-to-map SLAM: each scan is matched onto the map around its predicted pose, then
inserted into the occupancy grid at keyframes.

The prediction is the last pose moved by the odometry since the last scan (wheel or scan
odometry); without odometry, the last pose. The scan is matched onto ``tracking_field``. A
match is judged on the scan points that land on mapped ground: scans whose fit there is below
``min_score`` keep the predicted pose and are not inserted (counted), except on new ground,
which is mapped from the predicted pose so the map keeps growing ahead of the robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2, ScanPoints
from navd.slam.anchored_trajectory import AnchoredTrajectory
from navd.slam.graph_file import MapGraph
from navd.slam.heading_trust import HeadingTrust
from navd.slam.keyframe import EDGE_WEIGHTS, Keyframe, edge_to_new
from navd.slam.likelihood_field import LikelihoodField
from navd.slam.loop_closure import LoopCloser
from navd.slam.match_repair import (
    LOST_KNOWN_FRACTION,
    LOST_RUN,
    MIN_KNOWN_POINTS,
    REPAIR_KNOWN_FRACTION,
    ROBOT_CELL,
    MatchRepair,
)
from navd.slam.matcher import CorrelativeMatcher, Match
from navd.slam.motion_check import MotionCheck
from navd.slam.occupancy import OccupancyGrid
from navd.slam.pose_graph import Edge, optimize
from navd.slam.reported_pose import PoseRefiner
from navd.slam.scan_result import ScanResult, TrackingCounts
from navd.slam.settings import MapperSettings
from navd.slam.tracking_field import TrackingField
from navd.slam.two_priors import match_either
from navd.slam.voxel import voxel_downsample

__all__ = ["ScanMapper", "ScanResult"]

FloatArray = npt.NDArray[np.float64]

# A loop closure that disagrees with the map by less than this does not re-solve the graph.
LOOP_SETTLED_M, LOOP_SETTLED_RAD = 0.05, 0.01


def _tracking_matcher(s: MapperSettings) -> CorrelativeMatcher:
    return CorrelativeMatcher(
        search_xy_m=s.search_xy_m,
        search_yaw_rad=s.search_yaw_rad,
        reach_m=s.max_range_m / 2,
        prior_weight_per_m2=s.prior_weight_per_m2,
        prior_axis_weight_per_m2=s.prior_axis_weight_per_m2,
        point_spacing_m=s.voxel_size_m,
        prior_weight_per_rad2=s.prior_weight_per_rad2 or 0.0,
    )


@dataclass
class ScanMapper:
    """Builds the map and tracks the robot on it, one scan at a time.

    Attributes:
        settings: what it runs on.
        fine: refines each matched scan's reported pose (a replay's fine map), or None.
    """

    settings: MapperSettings = field(default_factory=MapperSettings.defaults)
    fine: PoseRefiner | None = None

    def __post_init__(self) -> None:
        s = self.settings
        self.grid = OccupancyGrid(s.resolution_m)
        self.matcher = _tracking_matcher(s)
        self._refinement = Pose2(0.0, 0.0, 0.0)  # last reported pose in the tracked one's frame
        self.pose: Pose2 | None = None
        self.keyframes: list[Keyframe] = []
        self.edges: list[Edge] = []
        self._trajectory = AnchoredTrajectory()  # kept only with keep_trajectory
        self.motion = MotionCheck(s.motion_limits)
        self.loops = LoopCloser(s)
        self.counts = TrackingCounts()
        self.heading_trust = HeadingTrust()
        self._last_odom: Pose2 | None = None
        self._weak_run = 0  # scans in a row that did not match the map
        self._misfit_run = 0  # scans in a row on mapped ground not fitting it, or doubtfully
        self.last_good: Pose2 | None = None  # the last pose a scan fitted the map at
        self.repair = MatchRepair(s, self.counts)
        self._base: OccupancyGrid | None = None  # a loaded map, under the keyframes
        self._new_session = False  # the next keyframe starts a new chain (a load, a set pose)
        self.tracking = TrackingField()  # what scans are matched on, around the robot

    def configure(self, settings: MapperSettings) -> None:
        """Take new settings (the search window, thresholds, updating_map) at once."""
        self.settings = settings
        self.matcher = _tracking_matcher(settings)
        self.motion.limits = settings.motion_limits
        if self.fine is not None:
            self.fine.configure(settings)
        self.loops.configure(settings)
        self.tracking.forget()
        self.repair.configure(settings)
        self._weak_run = 0
        self._misfit_run = 0

    def load(self, grid: OccupancyGrid, graph: MapGraph | None = None) -> None:
        """Start from a saved map. With the pose graph it was built from, mapping goes on
        where it stopped (its keyframes and edges are this run's first). Without one, or with
        one whose keyframes kept no scans (loop closure was off), the map stays under all
        mapped from here on, and a rebuild draws the new keyframes over it."""
        self.grid = grid
        if graph is None or any(f.scan is None and f.mapped for f in graph.keyframes):
            self._base = grid.copy()
            self.keyframes, self.edges = [], []
        else:
            self._base = graph.base
            self.keyframes, self.edges = list(graph.keyframes), list(graph.edges)
        self._trajectory.clear()
        self.motion.forget()
        self._new_session = True
        self.loops.held = []  # (their keyframe indices were of the keyframes replaced)
        self.tracking.forget()
        if self.fine is not None:
            self.fine.clear()

    def graph(self) -> MapGraph:
        """What the map was built from, for a save (a snapshot: frozen keyframes, copied lists)."""
        return MapGraph(tuple(self.keyframes), tuple(self.edges), self._base)

    def predict(self, odom: Pose2 | None) -> Pose2:
        """The pose now: the last pose moved by the odometry since then."""
        if self.pose is None:
            return odom if odom is not None else Pose2(0.0, 0.0, 0.0)
        if odom is None or self._last_odom is None:
            return self.pose
        return self.pose.compose(self._last_odom.between(odom))

    def trajectory(self) -> list[Pose2]:
        """Every scan's pose so far, as the latest pose graph places it (empty unless the
        settings say ``keep_trajectory``)."""
        return self._trajectory.poses(self.keyframes)

    def finish(self) -> None:
        """After the last scan: let go of the tracking field and the fine map, for writing
        the map out (a scan added afterwards is matched without the fine refinement)."""
        self.tracking.forget()
        self.fine = None

    def tracking_counts(self) -> dict[str, int | float]:
        """How tracking went so far: the replay summary's and the daemon status's counts."""
        return self.counts.as_dict(self.loops.counts, self.matcher.prior_weight_per_rad2)

    def forget_odometry(self) -> None:
        """The next scan's prediction is the set pose, not the pose moved by odometry (nor
        judged against the pose before it)."""
        self._last_odom = None
        self.motion.forget()

    def set_pose(self, pose: Pose2) -> None:
        """Put the robot at ``pose`` (an initial pose from a person, or a global search);
        it is no longer lost. The next keyframe is tied to the nearest old one, not to the
        last: the robot may have been carried from there."""
        self.pose = pose
        self._weak_run = 0
        self._misfit_run = 0
        self._new_session = True
        self.motion.forget()

    @property
    def lost(self) -> bool:
        """True once ``lost_after_scans`` scans in a row on mapped ground did not fit it, or
        fitted far worse than the scans before (doubtful): the pose is not to be trusted.
        The daemon then stops the robot and searches the map for it (``LostSearch``) instead
        of adding scans; a replay goes on, and a scan that fits again ends it."""
        n = self.settings.lost_after_scans
        return n > 0 and self._misfit_run >= n

    def _misfit(self) -> None:  # a scan on mapped ground that does not fit it
        self._misfit_run += 1
        if self._misfit_run == self.settings.lost_after_scans:
            self.counts.lost += 1

    def add(self, stamp: float, scan: ScanPoints, odom: Pose2 | None = None) -> ScanResult:
        """Locate one scan (robot frame) and add it to the map if it makes a keyframe."""
        self._refinement = Pose2(0.0, 0.0, 0.0)
        result = self._add(stamp, scan, odom)
        tracked = result.pose if self.pose is None else self.pose
        self.motion.record(stamp, tracked)
        if self.settings.keep_trajectory:
            self._trajectory.add(self.keyframes, tracked.compose(self._refinement))
        return result

    def _prior(self, stamp: float, odom: Pose2 | None) -> tuple[Pose2, bool, Pose2 | None]:
        """The predicted pose, whether odometry moved it, and, when that is a step no robot
        makes, the odometry's own prediction: the last step taken again (coasted) is the
        prediction then, and the scan decides between the two (``two_priors``)."""
        prior = self.predict(odom)
        odometry_step = odom is not None and self._last_odom is not None and self.pose is not None
        self._last_odom = odom
        coasted = self.motion.coasted()
        if odometry_step and coasted is not None and not self.motion.plausible(stamp, prior):
            return coasted, False, prior
        return prior, odometry_step, None

    def _match(
        self, points: FloatArray, prior: Pose2, odometry_step: bool, odometry: Pose2 | None
    ) -> tuple[Match, Pose2, bool]:
        """(match, its prior, whether odometry moved that): see ``_prior``."""
        match, prior, spike = match_either(
            self.matcher, self._field_around, points, prior, odometry
        )
        self.counts.odometry_spikes += spike
        return match, prior, odometry_step or (odometry is not None and not spike)

    def _add(self, stamp: float, scan: ScanPoints, odom: Pose2 | None) -> ScanResult:
        s = self.settings
        self.counts.scans += 1
        prior, odometry_step, other = self._prior(stamp, odom)
        if s.prior_weight_per_rad2 is None:
            self.matcher.prior_weight_per_rad2 = self.heading_trust.weight_per_rad2()
        if self.grid.empty:
            self.pose = prior
            cov = np.diag([s.resolution_m**2, s.resolution_m**2, 1e-4])
            if scan.hits.size == 0 and scan.misses.size == 0:
                # A blind sweep (a lidar spinning up sends zeros) starts no map: as the first
                # keyframe it would leave even the robot's cell unknown, and nothing after it
                # could be mapped.
                return ScanResult(prior, cov, 0.0, False, False)
            keyframe = self._insert(stamp, prior, scan)
            return ScanResult(prior, cov, 0.0, False, keyframe)
        points = voxel_downsample(scan.hits, s.voxel_size_m)
        match, prior, odometry_step = self._match(points, prior, odometry_step, other)
        # Judge the match on the part of the scan the map can explain: a robot driving into a
        # new corridor sees mostly never-mapped space, where every pose scores zero.
        known = self.grid.known_fraction(match.pose, points)
        known_points = known * points.shape[0]
        fit = match.score / known if known > 0.0 else 0.0
        on_mapped_ground = known_points >= MIN_KNOWN_POINTS and known >= REPAIR_KNOWN_FRACTION
        doubtful = False
        if on_mapped_ground:
            match, known, doubtful = self.repair.check(
                self.grid,
                self._field_around,
                points,
                prior=prior,
                match=match,
                known=known,
                weak_run=self._weak_run,
            )
            fit = match.score / known
        implausible = self.motion.jumped(stamp, prior, match.pose)  # then the prior stands
        self.counts.implausible += implausible
        if implausible or known_points < MIN_KNOWN_POINTS or fit < s.min_score:
            self.pose = prior
            cov = np.diag([s.search_xy_m**2, s.search_xy_m**2, s.search_yaw_rad**2])
            if (
                not implausible
                and known_points < MIN_KNOWN_POINTS
                and points.shape[0] >= MIN_KNOWN_POINTS
                and self.grid.known_fraction(prior, ROBOT_CELL) == 1.0
            ):
                # New ground with too little map to match against, seen from ground the map
                # knows: map it from the motion prior, or the map never grows there. A scan
                # whose part on mapped ground does not fit is doubtful, never mapped; and a
                # prior off the mapped ground is more likely wrong than new: dropped too.
                self.counts.exploring += 1
                return ScanResult(prior, cov, match.score, False, self._insert(stamp, prior, scan))
            self.counts.weak_matches += 1
            self._weak_run += 1  # (new ground mapped above is no sign of being lost)
            if known_points >= MIN_KNOWN_POINTS and known >= LOST_KNOWN_FRACTION:
                self._misfit()
            if s.loop_closure:
                # Lost on a map the robot drifted from is what a loop closure repairs.
                self._insert(stamp, prior, scan, mapped=False)
            return ScanResult(prior, cov, match.score, False, False)
        self.counts.matched += 1
        self._weak_run = 0
        if doubtful:
            self._misfit()
        else:
            self._misfit_run = 0
        self.repair.record(fit)
        pose = Pose2(float(match.pose.x), float(match.pose.y), float(match.pose.yaw))
        if odometry_step:
            self.heading_trust.record(pose.yaw - prior.yaw)
        self.pose = pose
        if not doubtful:
            self.last_good = pose
        # Reported refined on the fine map; tracked and mapped as matched (see fine_map).
        refined = self._refined(points, pose)
        keyframe = self._insert(stamp, pose, scan)
        reported = self._reported(pose, refined)
        return ScanResult(reported, match.covariance, match.score, True, keyframe)

    def _insert(self, stamp: float, pose: Pose2, scan: ScanPoints, mapped: bool = True) -> bool:
        """Make a keyframe if the robot moved far enough since the last; True if it did and
        the scan went into the map."""
        s = self.settings
        if not s.updating_map:
            return False
        if self.keyframes:
            moved = self.keyframes[-1].pose.between(pose)
            if (
                np.hypot(moved.x, moved.y) < s.keyframe_distance_m
                and abs(moved.yaw) < s.keyframe_angle_rad
            ):
                return False
        if mapped:
            self.grid.insert(pose, scan)
        if self.keyframes:
            self.edges.append(edge_to_new(self.keyframes, pose, found=self._new_session))
        self._new_session = False
        self.keyframes.append(Keyframe(stamp, pose, scan if s.loop_closure else None, mapped))
        if self.fine is not None and self._base is None:  # (not used over a base map)
            self.fine.add(self.keyframes)
        self.counts.keyframes += 1
        k = len(self.keyframes) - 1
        lost = self._weak_run >= LOST_RUN
        if s.loop_closure and (lost or k % s.loop_check_every == 0):
            self._close_loop(k)
        return mapped

    def _close_loop(self, k: int) -> None:
        """Tie keyframe ``k`` to the old passes it revisits; re-solve if it is off them."""
        unsettled = False
        for loop in self.loops.search(self.keyframes, self.edges, k):
            # (k, or for a far loop confirmed now, the earlier keyframe of the held match)
            z = self.keyframes[loop.old].pose.between(loop.pose)
            self.edges.append(Edge(loop.old, loop.new, z, EDGE_WEIGHTS, robust=True))
            off = self.keyframes[loop.new].pose.between(loop.pose)
            if math.hypot(off.x, off.y) >= LOOP_SETTLED_M or abs(off.yaw) >= LOOP_SETTLED_RAD:
                unsettled = True
        if unsettled:
            self._solve()

    def _solve(self) -> None:
        """Re-solve the pose graph, move the keyframes and rebuild the map from them."""
        self.counts.optimizations += 1
        before = np.array([tuple(f.pose) for f in self.keyframes])
        after = optimize(before, self.edges)
        last_old = self.keyframes[-1].pose
        self.keyframes = [
            Keyframe(f.stamp, Pose2(*map(float, p)), f.scan, f.mapped)
            for f, p in zip(self.keyframes, after, strict=True)
        ]
        self.rebuild_map()
        if self.pose is not None:
            # The robot moves with the newest keyframe.
            self.pose = self.keyframes[-1].pose.compose(last_old.between(self.pose))
            self.motion.moved_to(self.pose)

    def rebuild_map(self) -> None:
        """Draw the map again from the keyframes' scans at their poses (as the pose graph
        last placed them), over the loaded map if there is one."""
        base = self._base
        revision = self.grid.revision + 1
        # The old grid and field go before the new grid is drawn: a large map's tiles are
        # never held twice (fr-clinic's are 45 MB). Until this returns the grid is partly
        # drawn: whoever shares the mapper across threads holds their lock around it.
        self.tracking.forget()
        self.grid = OccupancyGrid(self.grid.resolution) if base is None else base.copy()
        for frame in self.keyframes:
            if frame.scan is not None and frame.mapped:
                self.grid.insert(frame.pose, frame.scan)
        self.grid.revision = revision
        if self.fine is not None:
            self.fine.clear()

    def _reported(self, matched: Pose2, refined: Pose2) -> Pose2:
        """The pose to report for a scan matched at ``matched`` and refined to ``refined``
        (moved with the robot if a loop closure re-solved the graph meanwhile)."""
        self._refinement = matched.between(refined)
        if self.pose is matched or self.pose is None:
            return refined
        return self.pose.compose(self._refinement)

    def _refined(self, points: FloatArray, pose: Pose2) -> Pose2:
        """``pose`` (a match on the map) refined on the fine map (see ``fine_map``); as it
        is without a fine map, or over a base map (one loaded without its keyframes' scans:
        what lies under it cannot be drawn finer)."""
        if self.fine is None or self._base is not None:
            return pose
        return self.fine.refine(self.keyframes, points, pose)

    def _field_around(self, prior: Pose2) -> LikelihoodField:
        """The likelihood field for matching near ``prior`` (reused while still valid)."""
        field, drawn = self.tracking.around(self.grid, prior, self.settings)
        self.counts.fields_built += drawn
        return field
