"""The collision guard: independent of the planner, it zeroes or slows a command that would
bring scan points into the stop or slow-down zone (Nav2's collision monitor idea).

For a command (v, ω) the footprint is swept along its arc over the time the robot needs to
brake (|v| / max linear deceleration, |ω| / max angular deceleration, plus one command
period), and the smallest distance from the swept footprint to any scan point is compared
with ``safety.stop_distance_m`` and ``safety.slowdown_distance_m``. Only motion that brings the
robot closer than it already is counts: backing away from a wall is always allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numba import njit

from navd.config import NavdConfig
from navd.geometry.footprint import Footprint
from navd.geometry.mount import SensorMounts
from navd.geometry.scan import laser_points, scan_points
from navd.lifecycle.messages import LaserScan, PoseEstimate
from navd.lifecycle.module import Module, ModuleContext
from navd.planning._dwa_kernels import footprint_distance
from navd.planning.layers import LIVE_SCAN_S
from navd.planning.zones import RECHECK_S, ZoneMasks

__all__ = ["CollisionGuard", "GuardSettings", "guard_scale", "warm_up_guard"]

FloatArray = npt.NDArray[np.float64]

# The sweep is sampled at least this finely [m of travel] and [rad of turn].
SWEEP_STEP_M = 0.02
SWEEP_STEP_RAD = 0.05
# Only what a braking robot can reach matters: scan points farther than this are not kept [m].
GUARD_REACH_M = 3.0


@dataclass(frozen=True, slots=True)
class GuardSettings:
    """The guard's plain values (see the module docstring)."""

    footprint: Footprint
    stop_m: float
    slowdown_m: float
    slowdown_factor: float
    linear_decel_mps2: float
    angular_decel_radps2: float
    period_s: float
    enabled: bool
    mounts: SensorMounts
    speed_mask: str | None = None
    max_speed_mps: float = math.inf

    @classmethod
    def from_config(cls, config: NavdConfig) -> GuardSettings:
        """The settings the safety, robot, chassis, lidar and mounts sections describe."""
        safety, robot = config.safety, config.robot
        return cls(
            footprint=Footprint.of(robot),
            stop_m=safety.stop_distance_m,
            slowdown_m=safety.slowdown_distance_m,
            slowdown_factor=safety.slowdown_factor,
            linear_decel_mps2=robot.max_linear_accel_mps2,
            angular_decel_radps2=robot.max_angular_accel_radps2,
            period_s=1.0 / config.chassis.command_rate_hz,
            enabled=safety.use_collisions,
            mounts=SensorMounts.of(config),
            speed_mask=config.planning.speed_mask,
            max_speed_mps=robot.max_linear_speed_mps,
        )


@njit(cache=True, nogil=True)
def _sweep_clearance(  # noqa: PLR0917
    points: FloatArray,
    v: float,
    w: float,
    duration: float,
    samples: int,
    kind: int,
    half_length: float,
    half_width: float,
) -> tuple[float, float]:
    """[m] (clearance now, smallest clearance along the sweep) of the footprint to the points
    (robot frame), the footprint moving at (v, ω) for ``duration`` [s]."""
    now = 1e9
    for q in range(points.shape[0]):
        now = min(
            now,
            footprint_distance(
                points[q, 0], points[q, 1], 0.0, 0.0, 1.0, 0.0, kind, half_length, half_width
            ),
        )
    swept = now
    for s in range(1, samples + 1):
        t = duration * s / samples
        yaw = w * t
        if abs(w) < 1e-9:
            x = v * t
            y = 0.0
        else:
            x = v / w * math.sin(yaw)
            y = v / w * (1.0 - math.cos(yaw))
        c = math.cos(yaw)
        sn = math.sin(yaw)
        for q in range(points.shape[0]):
            swept = min(
                swept,
                footprint_distance(
                    points[q, 0], points[q, 1], x, y, c, sn, kind, half_length, half_width
                ),
            )
    return now, swept


def guard_scale(
    points_m: FloatArray, linear_mps: float, angular_radps: float, s: GuardSettings
) -> tuple[float, str]:
    """The factor (0, the slow-down factor or 1) for a command, and why.

    Args:
        points_m: [m] M x 2 scan points in the robot frame.
        linear_mps, angular_radps: the command.
        s: the guard's settings.
    """
    if not s.enabled or points_m.shape[0] == 0 or (linear_mps == 0.0 and angular_radps == 0.0):
        return 1.0, ""
    if not _sweep_clearance.signatures:  # asked on the event loop, which must not compile
        return 0.0, "collision guard starting (its kernel is not loaded yet): stop"
    braking = max(
        abs(linear_mps) / s.linear_decel_mps2, abs(angular_radps) / s.angular_decel_radps2
    )
    duration = braking + s.period_s
    travel = abs(linear_mps) * duration + s.footprint.circumradius_m * abs(angular_radps) * duration
    samples = max(
        math.ceil(travel / SWEEP_STEP_M),
        math.ceil(abs(angular_radps) * duration / SWEEP_STEP_RAD),
        1,
    )
    fp = s.footprint
    now, swept = _sweep_clearance(
        points_m,
        linear_mps,
        angular_radps,
        duration,
        samples,
        fp.kind,
        fp.half_length_m,
        fp.half_width_m,
    )
    if swept >= now - 1e-6:
        return 1.0, ""  # moving away, or along: nothing comes closer
    if swept < s.stop_m:
        return 0.0, f"obstacle {max(swept, 0.0):.2f} m from the footprint on the way: stop"
    if swept < s.slowdown_m:
        return s.slowdown_factor, f"obstacle {swept:.2f} m from the footprint on the way: slow"
    return 1.0, ""


def warm_up_guard(settings: GuardSettings) -> None:
    """Load the guard's kernels: the sweep (``guard_scale`` stops the robot until it is
    loaded) and the scan's points (numpy does them until then)."""
    fp = settings.footprint
    points = scan_points(np.full(8, 1.0), -math.pi, math.pi / 4, range_min=0.1, range_max=8.0)
    _sweep_clearance(points.hits, 0.1, 0.1, 0.5, 4, fp.kind, fp.half_length_m, fp.half_width_m)
    guard_scale(points.hits, 0.1, 0.1, settings)


class CollisionGuard(Module):
    """Keeps each lidar's latest scan in the robot frame; the safety gate asks it about each
    command, against all of them together."""

    def __init__(self) -> None:
        super().__init__("collision_guard")
        self._points: FloatArray = np.empty((0, 2))
        self._by_lidar: dict[str, tuple[float, FloatArray]] = {}  # stamp [s], points
        self._pose: tuple[float, float] | None = None
        self.zones: ZoneMasks | None = None  # the speed mask, read in a worker

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(GuardSettings)
        ctx.subscribe(LaserScan, self._on_scan)
        ctx.subscribe(PoseEstimate, self._on_pose)

    async def on_activate(self) -> None:
        # Compile (or load) the kernel now, not on the event loop nor on the first command
        # of a moving robot.
        settings = self.settings.value
        self.ctx.warm_up(lambda: warm_up_guard(settings), name="warm-up")
        self.ctx.every(RECHECK_S, self._check_zones, name="speed-zones")

    def _check_zones(self, now: float) -> None:
        """Read the speed mask when the config names another, or its file changed (in a
        worker: an image may take a while to read)."""
        path = self.settings.value.speed_mask
        zones = self.zones

        def job() -> None:
            if zones is None or zones.paths[1] != path:
                self.zones = None if path is None else ZoneMasks(None, path)
            else:
                zones.refresh(now)

        if path is not None or zones is not None:
            self.ctx.submit("guard_zones", job)

    def _on_pose(self, pose: PoseEstimate) -> None:
        self._pose = (pose.x_m, pose.y_m)

    def settings_in_use(self) -> tuple[object, ...]:
        return (self.settings.value,)

    def _on_scan(self, scan: LaserScan) -> None:
        mount = self.settings.value.mounts.lidar(scan.device_id)
        # on the event loop: never compiles (before the warm-up, numpy does it)
        hits = laser_points(scan, mount, max_range_m=GUARD_REACH_M, loaded_only=True).hits
        by_lidar = self._by_lidar
        by_lidar[scan.device_id] = (scan.stamp, hits)
        if len(by_lidar) == 1:
            self._points = hits
            return
        # Another lidar's points count while its scans are current (a lidar gone quiet holds
        # the robot in the safety gate; one that left, or came back under a new id, must not
        # leave obstacles behind that move with the robot).
        for device in [d for d, (t, _) in by_lidar.items() if t < scan.stamp - LIVE_SCAN_S]:
            del by_lidar[device]
        self._points = np.concatenate([points for _, points in by_lidar.values()])

    def limit(self, linear_mps: float, angular_radps: float) -> tuple[float, float, str]:
        """The command scaled by the guard, and why ("" when untouched): slowed to a speed
        zone's limit where the robot is (whoever drives, a person too), then scaled for
        obstacles."""
        settings = self.settings.value
        zoned = ""
        zones, pose = self.zones, self._pose
        if zones is not None and zones.speed is not None and pose is not None:
            cap = zones.speed_fraction_at(*pose) * settings.max_speed_mps
            if abs(linear_mps) > cap:
                linear_mps = math.copysign(cap, linear_mps)
                zoned = f"speed zone: {cap:.2f} m/s"
        scale, reason = guard_scale(self._points, linear_mps, angular_radps, settings)
        return linear_mps * scale, angular_radps * scale, reason or zoned
