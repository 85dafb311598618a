"""What the daemon worked out: poses, localization, orientation, maps, routes, health."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.lifecycle.errors import MessageError
from navd.lifecycle.messages.base import (
    FloatArray,
    Message,
    Vector3,
    read_only,
    require_finite,
)

# --- results ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class PoseEstimate(Message):
    """The fused pose of base_link in the map frame.

    Attributes:
        x_m, y_m: [m] position.
        yaw_rad: [rad] heading, counter-clockwise from +x, in (-pi, pi].
        covariance: 3x3 covariance of (x [m], y [m], yaw [rad]) (read-only).
        linear_mps: [m/s] forward velocity.
        angular_radps: [rad/s] yaw rate.
    """

    x_m: float
    y_m: float
    yaw_rad: float
    covariance: FloatArray
    linear_mps: float = 0.0
    angular_radps: float = 0.0

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        cov = read_only("covariance", self.covariance, np.float64, 2)
        if cov.shape != (3, 3):
            raise MessageError(f"covariance must be 3x3, got shape {cov.shape}")
        object.__setattr__(self, "covariance", cov)

    @property
    def pose(self) -> Pose2:
        """The pose as a Pose2."""
        return Pose2(self.x_m, self.y_m, self.yaw_rad)


@dataclass(frozen=True, slots=True, kw_only=True)
class PoseMeasurement(Message):
    """A measured pose of base_link in the map frame (scan matching), for the estimator.

    Attributes:
        source: what measured it ("lidar").
        x_m, y_m: [m] position.
        yaw_rad: [rad] heading, counter-clockwise from +x.
        covariance: 3x3 covariance of (x [m], y [m], yaw [rad]) (read-only).
    """

    source: str
    x_m: float
    y_m: float
    yaw_rad: float
    covariance: FloatArray

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        for name in ("x_m", "y_m", "yaw_rad"):
            require_finite(name, getattr(self, name))
        cov = read_only("covariance", self.covariance, np.float64, 2)
        if cov.shape != (3, 3):
            raise MessageError(f"covariance must be 3x3, got shape {cov.shape}")
        if not (np.all(np.isfinite(cov)) and np.all(np.diag(cov) > 0.0)):
            raise MessageError("covariance must be finite with positive variances")
        object.__setattr__(self, "covariance", cov)

    @property
    def pose(self) -> Pose2:
        """The pose as a Pose2."""
        return Pose2(self.x_m, self.y_m, self.yaw_rad)


@dataclass(frozen=True, slots=True, kw_only=True)
class LocalizationState(Message):
    """How well the robot knows where it is: on every change, and once a second.

    Attributes:
        state: "uninitialized" (no position source yet), "ok", "degraded" or "lost".
        position_std_m: [m] standard deviation of the position along its worst axis.
        yaw_std_rad: [rad] standard deviation of the yaw.
        counters: the estimator's counts (late, rejected, ignored events, resets...).
        reason: why it is lost when the uncertainty does not say (scan matching lost the
            robot on its map); empty otherwise.
    """

    state: str
    position_std_m: float
    yaw_std_rad: float
    counters: Mapping[str, object] = field(default_factory=dict)
    reason: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class SlamTracking(Message):
    """How scan matching went since start (SLAM module), at most once a second.

    Attributes:
        counts: scans, matched, weak_matches (not matched, not mapped), exploring (new
            ground mapped from the odometry), doubtful, repaired (found again by a wider
            search), keyframes, loops_found, and heading_prior_weight_per_rad2.
    """

    counts: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        object.__setattr__(self, "counts", MappingProxyType(dict(self.counts)))


@dataclass(frozen=True, slots=True, kw_only=True)
class TrackingLost(Message):
    """Scan matching lost the robot on its map, or found it again (SLAM module), on change.

    While ``lost`` the estimate is not to be trusted, whatever its uncertainty says: the
    scans have stopped fitting the map where the estimate puts the robot (it was carried,
    its wheels slipped far, the map is of somewhere else). The SLAM module searches the map
    for the robot meanwhile and sends ``lost=False`` with an ``InitialPose`` when it found
    it.

    Attributes:
        lost: True from the scan that made the robot lost until a search found it.
        reason: why it is lost, or how it was found.
    """

    lost: bool
    reason: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Orientation(Message):
    """The IMU's orientation from Madgwick's filter, for scan deskewing and levelling.

    Attributes:
        device_id: the IMU.
        quaternion_wxyz: rotation of the IMU frame into the earth frame (z up; x magnetic
            north with a magnetometer, else the heading at start-up).
        gyro_bias_radps: [rad/s] the gyro bias learned so far.
    """

    device_id: str
    quaternion_wxyz: tuple[float, float, float, float]
    gyro_bias_radps: Vector3


class BeaconPlace(NamedTuple):
    """Where a beacon stands in the map frame.

    Attributes:
        beacon_id: its name.
        x_m, y_m: [m] its place.
        std_m: [m] 1-sigma of the place (0 for a place given in the config).
        learnt: learnt from bearings (False: given in the config).
        observations: how many observations of it have been taken.
    """

    beacon_id: str
    x_m: float
    y_m: float
    std_m: float
    learnt: bool
    observations: int


@dataclass(frozen=True, slots=True, kw_only=True)
class BeaconPlaces(Message):
    """Every beacon whose place is known or learnt (published when one changes, at most once
    a second, and once at start-up)."""

    places: tuple[BeaconPlace, ...]

    def place(self, beacon_id: str) -> BeaconPlace | None:
        """The beacon's place, or None if it has none."""
        return next((p for p in self.places if p.beacon_id == beacon_id), None)


@dataclass(frozen=True, slots=True, kw_only=True)
class MapUpdate(Message):
    """A snapshot of the occupancy grid.

    Attributes:
        revision: increases with every update.
        resolution_m: [m] cell size.
        origin_x_m, origin_y_m: [m] map-frame position of cell (0, 0)'s corner.
        occupancy: int8 grid, row = y index; -1 unknown, 0..100 occupied probability (%).
    """

    revision: int
    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    occupancy: npt.NDArray[np.int8]

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        if not self.resolution_m > 0.0:
            raise MessageError(f"resolution_m must be > 0, got {self.resolution_m}")
        object.__setattr__(self, "occupancy", read_only("occupancy", self.occupancy, np.int8, 2))


@dataclass(frozen=True, slots=True, kw_only=True)
class Path(Message):
    """A planned route in the map frame: ``points_m`` is an (N, 2) read-only array of [m]."""

    goal_id: str
    points_m: FloatArray

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        points = read_only("points_m", self.points_m, np.float64, 2)
        if points.shape[1] != 2:
            raise MessageError(f"points_m must have shape (N, 2), got {points.shape}")
        object.__setattr__(self, "points_m", points)


@dataclass(frozen=True, slots=True, kw_only=True)
class CostmapUpdate(Message):
    """The inflated costmap the last route was planned on, as ROS shows a costmap: int8
    cells, -1 unknown, 0 free .. 98 costly, 99 where the robot's centre cannot be (inscribed),
    100 an obstacle; row 0 at ``origin_y_m``. Published only while a viewer asks for it.

    Attributes:
        resolution_m: [m] cell size.
        origin_x_m, origin_y_m: [m] map position of cell (0, 0)'s corner.
        occupancy: rows x cols int8 (read-only).
    """

    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    occupancy: npt.NDArray[np.int8]

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        object.__setattr__(self, "occupancy", read_only("occupancy", self.occupancy, np.int8, 2))


@dataclass(frozen=True, slots=True, kw_only=True)
class LocalTrajectory(Message):
    """The local planner's chosen motion, rolled out over its horizon from the robot's
    pose. Published each control step only while a viewer asks for it.

    Attributes:
        goal_id: the goal driven to.
        linear_mps, angular_radps: the command chosen.
        points_m: N x 2 map positions along the rollout (read-only).
    """

    goal_id: str
    linear_mps: float
    angular_radps: float
    points_m: FloatArray

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        object.__setattr__(self, "points_m", read_only("points_m", self.points_m, np.float64, 2))


@dataclass(frozen=True, slots=True, kw_only=True)
class StuckDetected(Message):
    """The robot made no progress for planning.max_stuck_time_s (seed 001 §4.5).

    Attributes:
        goal_id: the goal being pursued.
        x_m, y_m: [m] where the robot is stuck (map frame).
        replans: how many times it has been stuck on this goal.
        giving_up: True when the goal fails because of it.
    """

    goal_id: str
    x_m: float
    y_m: float
    replans: int
    giving_up: bool


class ModuleHealth(NamedTuple):
    """How one module is doing, as reported in DaemonStatus."""

    name: str
    state: str
    handler_failures: int
    slow_handlers: int
    faulted: bool


class WorkerStats(NamedTuple):
    """Counters of one latest-wins worker slot."""

    slot: str
    submitted: int
    completed: int
    dropped: int
    failed: int


@dataclass(frozen=True, slots=True, kw_only=True)
class WorkerJob(Message):
    """One worker job's timing on the daemon's clock, published as it ends (recorded, so a
    replay runs each job when the real run did, not at once: docs/liveview.md).

    Attributes:
        slot: the job's latest-wins slot ("scan_match", "local_plan"...).
        submitted_s: [s] when it was handed to the pool.
        started_s, finished_s: [s] when it began to run, and when its result was published
            (NaN for a job dropped before it ran).
        outcome: "done", "failed", or "dropped" (a newer job of its slot replaced it).
    """

    slot: str
    submitted_s: float
    started_s: float = math.nan
    finished_s: float = math.nan
    outcome: str = "done"


@dataclass(frozen=True, slots=True, kw_only=True)
class SetUpDone(Message):
    """A module's set-up (kernels loading, a filter being built beside the loop) took
    effect, at ``stamp`` on the daemon's clock (recorded: a replay has it take effect then).

    Attributes:
        name: "<module>-<set-up>" ("estimation-setup").
    """

    name: str


@dataclass(frozen=True, slots=True, kw_only=True)
class LoopTicks(Message):
    """When a module's periodic loop ticked, on the daemon's clock, over about a second
    (recorded, so a replay ticks when the real run did: a loop held up by a busy machine is
    held up again).

    Attributes:
        loop: "<module>.<loop>" ("planner.control").
        times_s: [s] each tick's time, in order.
    """

    loop: str
    times_s: tuple[float, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class DaemonStatus(Message):
    """The daemon's own health, published at ``lifecycle.status_rate_hz``.

    Attributes:
        uptime_s: [s] since start.
        loop_lag_p50_ms, loop_lag_p99_ms, loop_lag_max_ms: [ms] event-loop lag over the
            recent window (how late a timer fires).
        modules: health of every module, in start order.
        workers: counters of every worker slot.
        safe_stop_reasons: why the robot is held still; empty when it may move.
        messages_dispatched: messages delivered since start.
    """

    uptime_s: float
    loop_lag_p50_ms: float
    loop_lag_p99_ms: float
    loop_lag_max_ms: float
    modules: tuple[ModuleHealth, ...]
    workers: tuple[WorkerStats, ...]
    safe_stop_reasons: tuple[str, ...]
    messages_dispatched: int
    extra: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        object.__setattr__(self, "extra", MappingProxyType(dict(self.extra)))
