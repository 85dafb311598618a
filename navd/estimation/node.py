"""The estimation module: wires ``StateEstimator`` to the bus.

Sensor messages go in as they arrive (each handler is one cheap filter step); at
``estimation.publish_rate_hz`` the module publishes the fused pose predicted to now, the IMU
orientation, and the localization state when it changes (and once a second); the beacons'
places once the filter exists and whenever a learnt one moves (at most once a second).
Losing localization after having had it is a safety stop until it is regained: the
uncertainty grown past ``estimation.lost_position_std_m``, or scan matching lost on its map
(``TrackingLost``, until the SLAM module found the robot again and re-seeded the estimate).
"""

from __future__ import annotations

import dataclasses
import math

from navd.estimation.errors import GeoError
from navd.estimation.estimator import Localization, StateEstimator
from navd.estimation.geo import open_projections_here
from navd.estimation.settings import EstimatorSettings
from navd.estimation.warmup import warm_up
from navd.lifecycle import Module, ModuleContext
from navd.lifecycle.messages import (
    BeaconObservation,
    BeaconPlaces,
    CompassHeading,
    GeoGoal,
    Goal,
    GoalStatus,
    GpsFix,
    Imu,
    InitialPose,
    LocalizationState,
    Orientation,
    PoseMeasurement,
    SafeStop,
    SafeStopCleared,
    TrackingLost,
    WheelOdometry,
)

__all__ = ["EstimationNode"]

SAFE_STOP_KEY = "localization"
_STATE_REFRESH_S = 1.0
_BEACONS_EVERY_S = 1.0


class EstimationNode(Module):
    """Fuses sensor messages into PoseEstimate, Orientation and LocalizationState; turns
    latitude/longitude goals into map-frame goals."""

    def __init__(self) -> None:
        super().__init__("estimation")
        self._state = Localization.UNINITIALIZED
        self._state_published_at = -math.inf
        self._imu_device = ""
        self._stopped = False
        self._beacons_published: tuple[object, ...] | None = None
        self._beacons_logged: set[str] = set()  # learnt beacons whose placing was logged
        self._lost_on_map = ""  # why scan matching lost the robot; empty while it has not

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(EstimatorSettings.from_config, self._settings_changed)
        self.estimator: StateEstimator | None = None
        self.before_ready = 0
        self._pending_pose: InitialPose | None = None
        self._pending_geo_goal: GeoGoal | None = None
        self._build_error: Exception | None = None
        self._built: StateEstimator | None = None  # by the set-up's thread, to install
        ctx.subscribe(Imu, self._on_imu)
        ctx.subscribe(PoseMeasurement, self._on_pose)
        ctx.subscribe(GpsFix, self._on_gps)
        ctx.subscribe(CompassHeading, self._on_compass)
        ctx.subscribe(WheelOdometry, self._on_wheels)
        ctx.subscribe(BeaconObservation, self._on_beacon)
        ctx.subscribe(InitialPose, self._on_initial_pose)
        ctx.subscribe(GeoGoal, self._on_geo_goal)
        ctx.subscribe(TrackingLost, self._on_tracking)

    async def on_activate(self) -> None:
        # Building the filter loads its kernels (compiling them on a cold cache), so it
        # happens beside start-up, in a daemon thread that never holds up an exit;
        # measurements that come before are counted and dropped (the robot has just
        # started: localization is uninitialized anyway).
        self.ctx.warm_up(self._build, name="setup", then=self._install)
        # GPS fixes are projected here, on the event loop; pyproj opens its database once per
        # thread, so that is done now (about 2 ms, before the daemon is ready), not on the
        # first fix.
        open_projections_here()
        period_s = self.settings.value.publish_period_s  # needs a restart
        self.ctx.every(period_s, self._publish, name="publish")
        self.ctx.every(_BEACONS_EVERY_S, self._publish_beacons, name="beacons")

    def settings_in_use(self) -> tuple[object, ...]:
        estimator = self.estimator
        parts = () if estimator is None else estimator.settings_in_use()
        return (self.settings.value, *parts)

    def _build(self) -> None:
        """Worker thread: the estimator, installed by ``_install`` on the event loop."""
        try:
            # the kernels first: samples are dropped until the estimator exists, never
            # compiled for on the event loop
            warm_up(self.settings.value.estimation)
            self._built = StateEstimator(self.settings.value)
        except Exception as err:
            self._build_error = err

    def _install(self) -> None:
        if self._built is None:
            return
        self.estimator, self._built = self._built, None
        self.ctx.log.info("estimator_ready", dropped_before=self.before_ready)

    def _settings_changed(self, _old: EstimatorSettings, new: EstimatorSettings) -> None:
        if self.estimator is not None:
            self.estimator.configure(new)

    def _ready(self) -> StateEstimator | None:
        if self.estimator is None:
            self.before_ready += 1
        return self.estimator

    def _on_imu(self, imu: Imu) -> None:
        self._imu_device = imu.device_id
        if estimator := self._ready():
            estimator.add_imu(imu)

    def _on_pose(self, pose: PoseMeasurement) -> None:
        if estimator := self._ready():
            estimator.add_pose(pose, self.ctx.clock.now())

    def _on_gps(self, fix: GpsFix) -> None:
        if estimator := self._ready():
            estimator.add_gps(fix, self.ctx.clock.now())

    def _on_compass(self, heading: CompassHeading) -> None:
        if estimator := self._ready():
            estimator.add_compass(heading, self.ctx.clock.now())

    def _on_wheels(self, odom: WheelOdometry) -> None:
        if estimator := self._ready():
            estimator.add_wheel_odometry(odom, self.ctx.clock.now())

    def _on_beacon(self, seen: BeaconObservation) -> None:
        if estimator := self._ready():
            estimator.add_beacon(seen, self.ctx.clock.now())

    def _publish_beacons(self, now: float) -> None:
        """The beacons' places, when they differ from the last published (or at first)."""
        estimator = self.estimator
        if estimator is None:
            return
        version = (estimator.settings.beacons.known, estimator.beacon_map.revision)
        if version == self._beacons_published:
            return
        self._beacons_published = version
        places = estimator.beacon_places()
        for place in places:
            if place.learnt and place.beacon_id not in self._beacons_logged:
                self._beacons_logged.add(place.beacon_id)
                self.ctx.log.info(
                    "beacon_placed",
                    beacon=place.beacon_id,
                    x=round(place.x_m, 2),
                    y=round(place.y_m, 2),
                    std_m=round(place.std_m, 2),
                )
        self.ctx.publish(BeaconPlaces(stamp=now, received=now, places=places))

    def _on_tracking(self, tracking: TrackingLost) -> None:
        self._lost_on_map = tracking.reason if tracking.lost else ""

    def _on_initial_pose(self, pose: InitialPose) -> None:
        self.ctx.log.info("initial_pose", x=pose.x_m, y=pose.y_m, yaw=pose.yaw_rad)
        if self.estimator is None:
            self._pending_pose = pose  # a person's word is kept until the filter exists
        else:
            self.estimator.set_pose(pose)

    def _on_geo_goal(self, goal: GeoGoal) -> None:
        """A latitude/longitude goal becomes a map-frame Goal through the GPS datum (one
        that comes while the filter is being built waits for it: the datum may be there)."""
        if self.estimator is None:
            self._pending_geo_goal = goal
            return
        now = self.ctx.clock.now()
        geo = self.estimator.geo if self.estimator is not None else None
        reason = ""
        if geo is None:
            reason = (
                "no GPS datum yet: set world.datum_latitude_deg/longitude_deg or wait for a "
                "good fix, or send the goal in map x, y"
            )
        else:
            try:
                x, y = geo.to_map(goal.latitude_deg, goal.longitude_deg)
            except GeoError as err:
                reason = str(err)
        if reason:
            self.ctx.log.warning("geo_goal_refused", goal_id=goal.goal_id, reason=reason)
            self.ctx.publish(
                GoalStatus(
                    stamp=now, received=now, goal_id=goal.goal_id, state="failed", reason=reason
                )
            )
            return
        self.ctx.log.info(
            "geo_goal", goal_id=goal.goal_id, lat=goal.latitude_deg, lon=goal.longitude_deg
        )
        self.ctx.publish(
            Goal(
                stamp=goal.stamp,
                received=now,
                goal_id=goal.goal_id,
                x_m=x,
                y_m=y,
                yaw_rad=goal.yaw_rad,
            )
        )

    def _publish(self, now: float) -> None:
        if self._build_error is not None:
            error, self._build_error = self._build_error, None
            raise error  # reported by supervision as this module's failure
        estimator = self.estimator
        if estimator is None:
            return
        if estimator.settings is not self.settings.value:
            # A change that came while the filter was being built in its thread.
            estimator.configure(self.settings.value)
        if self._pending_pose is not None:
            # Given while the filter was being built: it means "the robot is here now".
            estimator.set_pose(dataclasses.replace(self._pending_pose, stamp=now))
            self._pending_pose = None
        if self._pending_geo_goal is not None:
            goal, self._pending_geo_goal = self._pending_geo_goal, None
            self._on_geo_goal(goal)
        estimator.advance(now)
        estimate = estimator.estimate(now)
        if estimate is not None:
            self.ctx.publish(estimate)
        if estimator.madgwick.initialized:
            self.ctx.publish(
                Orientation(
                    stamp=estimator.madgwick.last_stamp,
                    received=now,
                    device_id=self._imu_device,
                    quaternion_wxyz=estimator.madgwick.quaternion,
                    gyro_bias_radps=estimator.madgwick.gyro_bias_radps,
                )
            )
        state, position_std, yaw_std = estimator.localization(estimate)
        reason = ""
        if self._lost_on_map and state != Localization.UNINITIALIZED:
            state, reason = Localization.LOST, self._lost_on_map
        changed = state != self._state
        if changed or now - self._state_published_at >= _STATE_REFRESH_S:
            self._state_published_at = now
            self.ctx.publish(
                LocalizationState(
                    stamp=now,
                    received=now,
                    state=state,
                    position_std_m=position_std,
                    yaw_std_rad=yaw_std,
                    counters=estimator.counters,
                    reason=reason,
                )
            )
        if changed:
            self.ctx.log.info(
                "localization",
                state=state,
                previous=self._state,
                position_std_m=position_std,
                reason=reason or None,
            )
            self._state = state
            self._guard(state, position_std, now, reason)

    def _guard(self, state: str, position_std: float, now: float, why: str) -> None:
        """Hold the robot while localization is lost; release when it is back."""
        if state == Localization.LOST and not self._stopped:
            self._stopped = True
            reason = f"localization lost: {why or f'position std {position_std:.2f} m'}"
            self.ctx.publish(
                SafeStop(
                    stamp=now, received=now, reason=reason, source=self.name, key=SAFE_STOP_KEY
                )
            )
        elif state in (Localization.OK, Localization.DEGRADED) and self._stopped:
            self._stopped = False
            self.ctx.publish(
                SafeStopCleared(stamp=now, received=now, key=SAFE_STOP_KEY, source=self.name)
            )
