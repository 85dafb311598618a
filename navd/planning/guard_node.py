"""The collision guard's module: each lidar's latest scan in the robot frame, and each range
sensor's and depth camera's latest points, which the safety gate asks about every command
(``guard`` computes the answer)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.geometry import band_points, cone_points, laser_points
from navd.lifecycle import Module, ModuleContext
from navd.lifecycle.messages import DepthPoints, LaserScan, PoseEstimate, RangeReading
from navd.planning.guard import GUARD_REACH_M, guard_scale, warm_up_guard
from navd.planning.live_points import LIVE_SCAN_S
from navd.planning.settings import guard_settings
from navd.planning.zones import RECHECK_S, ZoneMasks

__all__ = ["CollisionGuard"]

FloatArray = npt.NDArray[np.float64]


class CollisionGuard(Module):
    """Keeps each source's latest points in the robot frame (a lidar's scan, a range
    sensor's cone, a depth camera's points in its height band); the safety gate asks it
    about each command, against all of them together."""

    def __init__(self) -> None:
        super().__init__("collision_guard")
        self._points: FloatArray = np.empty((0, 2))
        self._by_source: dict[str, tuple[float, FloatArray]] = {}  # stamp [s], points
        self._pose: tuple[float, float] | None = None
        self.zones: ZoneMasks | None = None  # the speed mask, read in a worker

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(guard_settings)
        ctx.subscribe(LaserScan, self._on_scan)
        ctx.subscribe(RangeReading, self._on_range)
        ctx.subscribe(DepthPoints, self._on_depth)
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
        self._take(scan.device_id, scan.stamp, hits)

    def _on_range(self, reading: RangeReading) -> None:
        mount = self.settings.value.mounts.body.range_sensor(reading.sensor)  # (checked)
        cone = cone_points(
            reading.range_m, reading.field_of_view_rad, reading.max_range_m, mount, GUARD_REACH_M
        )
        self._take(f"range:{reading.sensor}", reading.stamp, cone.hits)

    def _on_depth(self, depth: DepthPoints) -> None:
        mount = self.settings.value.mounts.body.depth_camera(depth.sensor)  # (checked)
        self._take(f"depth:{depth.sensor}", depth.stamp, band_points(depth.points_m, mount).hits)

    def _take(self, source: str, stamp: float, hits: FloatArray) -> None:
        """``source``'s latest points. Another source's count while they are current (a
        lidar gone quiet holds the robot in the safety gate; one that left, or came back
        under a new id, must not leave obstacles behind that move with the robot)."""
        by_source = self._by_source
        by_source[source] = (stamp, hits)
        if len(by_source) == 1:
            self._points = hits
            return
        for old in [s for s, (t, _) in by_source.items() if t < stamp - LIVE_SCAN_S]:
            del by_source[old]
        self._points = np.concatenate([points for _, points in by_source.values()])

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
