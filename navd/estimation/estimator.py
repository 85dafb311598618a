"""The state estimator: sensors in, fused pose out. Plain computation, driven by its node.

Madgwick's filter takes every IMU sample; position sources (scan-matched lidar poses, GPS
fixes, compass headings, wheel odometry, ranges and bearings to beacons at known places)
become time-stamped events for the UKF (``event_filter``), each with the rows every event
carries (``event_rows``). The filter starts
at the first absolute position (a lidar pose, a GPS fix once the datum exists, ranges to
three known beacons within a second, or an initial pose from a client); until then nothing
is estimated. Beacons not at known places have their places learnt (``beacon_map``).
"""

from __future__ import annotations

import math
from collections import Counter
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from navd.estimation._ukf_kernels import propagate
from navd.estimation.beacon_map import BeaconMap
from navd.estimation.bearing import compass_yaw
from navd.estimation.errors import GeoError
from navd.estimation.event_filter import EventFilter
from navd.estimation.event_rows import event_measurement
from navd.estimation.geo import GeoFrame
from navd.estimation.geo_anchor import GeoAnchor
from navd.estimation.history import Event, Insert
from navd.estimation.imu_mounts import ImuMounts
from navd.estimation.localization import Localization, localization_of
from navd.estimation.madgwick import MadgwickFilter
from navd.estimation.motion_model import (
    TH,
    VTH,
    VX,
    VY,
    ProcessNoise,
    Row,
    X,
    Y,
    transition_matrix,
)
from navd.estimation.range_start import RangeStart
from navd.estimation.settings import EstimatorSettings
from navd.estimation.ukf import MAX_YAW_STD_RAD, Measurement, PoseUkf
from navd.geometry import wrap_angle
from navd.lifecycle.messages import (
    BeaconObservation,
    BeaconPlace,
    CompassHeading,
    GpsFix,
    Imu,
    InitialPose,
    PoseEstimate,
    PoseMeasurement,
    WheelOdometry,
)
from navd.logs import get_logger

__all__ = ["Localization", "StateEstimator"]

# The position and yaw rows and columns of the state covariance (made once: np.ix_ per
# estimate was a tenth of its cost).
_POSE_BLOCK = np.ix_((X, Y, TH), (X, Y, TH))

FloatArray = npt.NDArray[np.float64]


_log = get_logger("estimation")


class _CompassYaw(NamedTuple):
    """The last compass reading as a map yaw: [s] stamp, [rad] yaw and its 1-sigma."""

    stamp: float
    yaw_rad: float
    std_rad: float


class StateEstimator:
    """Fuses IMU, lidar poses, GPS, compass and wheel odometry into one pose.

    Args:
        settings: the estimation and world sections; ``configure`` swaps them.
    """

    def __init__(self, settings: EstimatorSettings) -> None:
        self.settings = settings
        self.madgwick = MadgwickFilter(settings.estimation)
        self._ignored: Counter[str] = Counter()  # inputs left out, by why
        self.anchor = GeoAnchor(settings.world)  # the map's place on the earth, when known
        self._last_compass_yaw: _CompassYaw | None = None
        self._imu_mounts = ImuMounts(settings.mounts)  # each IMU turned into base_link
        est = settings.estimation
        self._q_poly = ProcessNoise(
            est.accel_noise_mps2**2, est.angular_accel_noise_radps2**2
        ).polynomial
        self.history = EventFilter(PoseUkf(settings.ukf), settings.history, settings.estimation)
        self.beacon_map = BeaconMap(settings.beacons.gate_chi2)
        self._range_start = RangeStart()  # ranges to known beacons, until they place it

    @property
    def geo(self) -> GeoFrame | None:
        """The geographic frame GNSS fixes are projected through, None before a datum."""
        return self.anchor.frame

    # --- configuration --------------------------------------------------------------------

    def configure(self, settings: EstimatorSettings) -> None:
        """Take new settings; the filter state, the IMU orientation and the map's
        geographic anchor are kept (a new datum or frame re-anchors the GPS conversion).

        Raises:
            GeoError: the new world section's datum cannot be projected (nothing changes).
        """
        self.anchor.configure(settings.world)
        self.settings = settings
        self._imu_mounts = ImuMounts(settings.mounts)
        est = settings.estimation
        self._q_poly = ProcessNoise(
            est.accel_noise_mps2**2, est.angular_accel_noise_radps2**2
        ).polynomial
        self.madgwick.configure(est)
        self.beacon_map.gate_chi2 = settings.beacons.gate_chi2
        self.history.settings = settings.history
        self.history.estimation = est
        ukf = settings.ukf
        if ukf != self.history.ukf.settings:
            self.history.ukf = PoseUkf(ukf)  # the state lives in the history, not the filter

    def settings_in_use(self) -> tuple[object, ...]:
        """The settings each part holds now."""
        history = self.history
        parts: tuple[object, ...] = (
            self.settings,
            self.madgwick.settings,
            history.settings,
            history.ukf.settings,
        )
        return parts if self.geo is None else (*parts, self.geo.projection)

    # --- inputs ---------------------------------------------------------------------------

    def add_imu(self, imu: Imu) -> bool:
        """Feed one IMU sample, turned into base_link by its mount, to Madgwick's filter;
        False if it was out of order."""
        return self.madgwick.update(self._imu_mounts.to_base_link(imu))

    def add_pose(self, pose: PoseMeasurement, now: float) -> Insert | None:
        """A scan-matched pose; starts the filter if nothing has yet."""
        cov = pose.covariance
        if not self.history.initialized:
            self.history.start(pose.stamp, pose.x_m, pose.y_m, pose.yaw_rad, cov)
            return None
        measurement = self._measurement(
            (Row.X, Row.Y, Row.YAW),
            [pose.x_m, pose.y_m, wrap_angle(pose.yaw_rad)],
            cov,
            pose.stamp,
        )
        gate = self.settings.estimation.lidar_gate_chi2
        return self.history.insert_logged(Event(pose.stamp, pose.source, measurement, gate), now)

    def add_gps(self, fix: GpsFix, now: float) -> Insert | None:
        """A GNSS fix: ignored if stale, before a datum exists, or off the map."""
        world = self.settings.world
        if now - fix.stamp > world.coords_lifetime_s:
            self._ignored["gps_stale"] += 1
            return None
        if self.geo is None and not self._take_datum(fix):
            return None
        assert self.geo is not None
        try:
            x, y = self.geo.to_map(fix.latitude_deg, fix.longitude_deg)
        except GeoError:
            self._ignored["gps_off_map"] += 1
            return None
        variance = fix.horizontal_accuracy_m**2
        if not self.history.initialized:
            yaw, yaw_std = self._start_heading(now)
            dx, dy = self._antenna_m(fix.device_id, yaw)
            x, y = x - dx, y - dy
            self.history.start(fix.stamp, x, y, yaw, np.diag([variance, variance, yaw_std**2]))
            return None
        # The fix is the antenna's; the centre is the lever arm behind it, turned by the
        # heading the filter predicts for the fix's time.
        dx, dy = self._antenna_m(fix.device_id, None, fix.stamp)
        x, y = x - dx, y - dy
        measurement = self._measurement(
            (Row.X, Row.Y), [x, y], np.diag([variance, variance]), fix.stamp
        )
        gate = self.settings.estimation.gps_gate_chi2
        return self.history.insert_logged(Event(fix.stamp, "gps", measurement, gate), now)

    def _take_datum(self, fix: GpsFix) -> bool:
        """Anchor the map to ``fix`` if it is good enough; the robot keeps its map position."""
        if fix.horizontal_accuracy_m > self.settings.estimation.datum_max_accuracy_m:
            self._ignored["gps_before_datum"] += 1
            return False
        at_xy = (0.0, 0.0)
        if self.history.initialized:
            estimate = self.history.predict_to(self.history.latest.x, fix.stamp)
            dx, dy = self._antenna_m(fix.device_id, float(estimate[TH]))
            at_xy = (float(estimate[X]) + dx, float(estimate[Y]) + dy)
        try:
            self.anchor.anchor(fix.latitude_deg, fix.longitude_deg, at_xy)
        except GeoError:
            self._ignored["gps_off_map"] += 1
            return False
        return True

    def add_compass(self, heading: CompassHeading, now: float) -> Insert | None:
        """A compass bearing, converted to map yaw (never used as a yaw unconverted)."""
        yaw = compass_yaw(
            heading,
            self.settings.world,
            grid_convergence_rad=self.geo.grid_convergence_rad if self.geo else 0.0,
            mount_yaw_rad=self.settings.mounts.compass_yaw_rad(heading.device_id),
        )
        std = math.radians(heading.accuracy_deg)
        self._last_compass_yaw = _CompassYaw(heading.stamp, yaw, std)
        if not self.history.initialized:
            return None
        measurement = self._measurement((Row.YAW,), [yaw], np.array([[std * std]]), heading.stamp)
        gate = self.settings.estimation.compass_gate_chi2
        return self.history.insert_logged(Event(heading.stamp, "compass", measurement, gate), now)

    def add_wheel_odometry(self, odom: WheelOdometry, now: float) -> Insert | None:
        """Wheel encoder velocities (only once the filter runs; they carry no position)."""
        if not self.history.initialized:
            return None
        est = self.settings.estimation
        r = np.diag([est.wheel_linear_std_mps**2, est.wheel_angular_std_radps**2])
        measurement = self._measurement(
            (Row.VELOCITY_FORWARD, Row.YAW_RATE),
            [odom.linear_mps, odom.angular_radps],
            r,
            odom.stamp,
        )
        event = Event(odom.stamp, "wheel", measurement, est.wheel_gate_chi2)
        return self.history.insert_logged(event, now)

    def add_beacon(self, seen: BeaconObservation, now: float) -> Insert | None:
        """A range and/or bearing to a beacon: fused if the beacon's place is known, else
        taken to learn its place (once the filter runs and if learning is on)."""
        beacons = self.settings.beacons
        place = beacons.known.get(seen.beacon_id)
        if place is None:
            if not beacons.learn:
                self._ignored["beacon_unknown"] += 1
            elif not self.history.initialized:
                self._ignored["beacon_before_start"] += 1
            else:
                self.beacon_map.observe(
                    seen.beacon_id,
                    self.history.pose_at(seen.stamp),
                    range_m=seen.range_m,
                    range_std_m=seen.range_std_m,
                    bearing_rad=seen.bearing_rad,
                    bearing_std_rad=seen.bearing_std_rad,
                )
            return None
        point = (place.x_m, place.y_m)
        if not self.history.initialized:
            found = None
            if seen.has_range:
                found = self._range_start.add(
                    seen.beacon_id, seen.stamp, seen.range_m, seen.range_std_m, beacons.known
                )
            if found is not None:  # where the latest ranges agree (``range_start``)
                yaw, yaw_std = self._start_heading(seen.stamp)
                cov = np.zeros((3, 3))
                cov[:2, :2] = found[1]
                cov[2, 2] = yaw_std**2
                self.history.start(seen.stamp, float(found[0][0]), float(found[0][1]), yaw, cov)
            return None
        rows: tuple[Row, ...] = ()
        values: list[float] = []
        variances: list[float] = []
        if seen.has_range:
            rows, values, variances = (Row.RANGE,), [seen.range_m], [seen.range_std_m**2]
        if seen.has_bearing:
            rows += (Row.BEARING,)
            values.append(seen.bearing_rad)
            variances.append(seen.bearing_std_rad**2)
        measurement = self._measurement(
            rows, values, np.diag(variances), seen.stamp, points=[point] * len(rows)
        )
        return self.history.insert_logged(
            Event(seen.stamp, "beacon", measurement, beacons.gate_chi2), now
        )

    def beacon_places(self) -> tuple[BeaconPlace, ...]:
        """Every beacon with a place: the config's, then those learnt so far."""
        return self.beacon_map.places(self.settings.beacons.known)

    def set_pose(self, pose: InitialPose) -> None:
        """Restart the filter at a pose given by a person (forgets the events)."""
        var_xy = pose.std_xy_m**2
        cov = np.diag([var_xy, var_xy, pose.std_yaw_rad**2])
        self.history.start(pose.stamp, pose.x_m, pose.y_m, pose.yaw_rad, cov)

    def advance(self, now: float) -> int:
        """Apply events that were stamped in the future and whose time has come."""
        if not self.history.initialized:
            return 0
        return self.history.advance(now)

    # --- outputs --------------------------------------------------------------------------

    def estimate(self, now: float) -> PoseEstimate | None:
        """The pose predicted to ``now`` [s] from the newest state, or None before the start."""
        if not self.history.initialized:
            return None
        latest = self.history.latest
        x, p = propagate(latest.x, latest.p, max(now - latest.stamp, 0.0), self._q_poly)
        yaw = wrap_angle(float(x[TH]))
        cov = p[_POSE_BLOCK]
        forward = math.cos(yaw) * x[VX] + math.sin(yaw) * x[VY]
        return PoseEstimate(
            stamp=now,
            received=now,
            x_m=float(x[X]),
            y_m=float(x[Y]),
            yaw_rad=yaw,
            covariance=cov,
            linear_mps=float(forward),
            angular_radps=float(x[VTH]),
        )

    def localization(self, estimate: PoseEstimate | None) -> tuple[str, float, float]:
        """(state, position std [m], yaw std [rad]) of ``estimate``."""
        return localization_of(estimate, self.settings.estimation)

    @property
    def counters(self) -> dict[str, object]:
        """Everything counted so far, for status and logs."""
        c = self.history.counters
        return {
            "events_applied": c.applied,
            "late_events": c.replayed,
            "events_reapplied": c.reapplied,
            "deferred": c.deferred,
            "too_old": c.too_old,
            "overflow": c.overflow,
            "resets": c.resets,
            "rejected": dict(c.rejected),
            "ignored": dict(self._ignored),
            **self.madgwick.counters,
        }

    # --- helpers --------------------------------------------------------------------------

    def _start_heading(self, at: float) -> tuple[float, float]:
        """[rad] the heading, and its std, a start from a place alone takes at ``at`` [s]:
        a compass reading's from the last second, else unknown."""
        compass = self._last_compass_yaw
        if compass is not None and at - compass.stamp < 1.0:
            return compass.yaw_rad, compass.std_rad
        return 0.0, MAX_YAW_STD_RAD

    def _antenna_m(
        self, device_id: str, yaw_rad: float | None, stamp: float = 0.0
    ) -> tuple[float, float]:
        """[m] the antenna's offset from the robot's centre in the map frame, at heading
        ``yaw_rad`` (None: the filter's predicted heading at ``stamp``)."""
        ox, oy = self.settings.mounts.gps_offset_m(device_id)
        if ox == 0.0 and oy == 0.0:
            return 0.0, 0.0
        if yaw_rad is None:  # the heading at the fix's time, not the newest one
            then = self.history.at_or_before(stamp)
            dt = max(stamp - then.stamp, 0.0)
            yaw_rad = float((transition_matrix(dt) @ then.x)[TH])
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        return c * ox - s * oy, s * ox + c * oy

    def _measurement(
        self,
        rows: tuple[Row, ...],
        z: list[float],
        r: FloatArray,
        stamp: float,
        *,
        points: list[tuple[float, float]] | None = None,
    ) -> Measurement:
        """The sensor's rows with the IMU window's and the no-sliding constraint's
        (``event_rows``)."""
        est = self.settings.estimation
        imu = self.madgwick.window_mean(stamp, est.imu_window_s)
        return event_measurement(rows, z, r, imu, est, points=points)
