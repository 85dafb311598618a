"""The state estimator: sensors in, fused pose out. Plain computation, driven by its node.

Madgwick's filter takes every IMU sample; position sources (scan-matched lidar poses, GPS
fixes, compass headings, wheel odometry, ranges and bearings to beacons at known places)
become time-stamped events for the UKF, each
carrying the IMU's mean yaw rate and acceleration over the window before it and, for a
differential drive, the constraint that the robot does not slide sideways. The filter starts
at the first absolute position (a lidar pose, a GPS fix once the datum exists, ranges to
three known beacons within a second, or an initial pose from a client); until then nothing
is estimated. Beacons not at known places have their places learnt (``beacon_map``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from navd.config import WorldConfig
from navd.estimation._ukf_kernels import propagate
from navd.estimation.beacon_map import BeaconMap, RobotPose
from navd.estimation.bearing import bearing_to_yaw
from navd.estimation.errors import GeoError
from navd.estimation.geo import GeoFrame
from navd.estimation.history import Event, EventHistory, Insert
from navd.estimation.madgwick import MadgwickFilter
from navd.estimation.motion_model import (
    STATE_SIZE,
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
    Vector3,
    WheelOdometry,
)
from navd.logs import get_logger

__all__ = ["Localization", "StateEstimator"]

# The position and yaw rows and columns of the state covariance (made once: np.ix_ per
# estimate was a tenth of its cost).
_POSE_BLOCK = np.ix_((X, Y, TH), (X, Y, TH))

FloatArray = npt.NDArray[np.float64]


_log = get_logger("estimation")
_IMU_ROWS = (Row.YAW_RATE, Row.ACCEL_FORWARD, Row.ACCEL_LEFT)
# [s] ranges to known beacons this recent together place the robot when nothing else has.
RANGE_START_S = 1.0
# Known beacons whose ranges start the filter (three: the place is not mirrored; four when
# there are: one bad range is then seen and left out).
RANGE_START_BEACONS = 3
# A range farther than this many of its sigmas from the place they agree on is left out.
RANGE_START_SIGMAS = 4.0

_Rows = tuple[tuple[float, ...], ...]  # a 3 x 3 rotation, row by row
_UNKNOWN: _Rows = ()  # an IMU whose mount is not looked up yet


def _rotate(rows: _Rows, v: Vector3) -> Vector3:
    """``rows`` times the vector ``v`` (plain floats: cheaper than numpy at 1 kHz)."""
    x, y, z = v
    a, b, c = rows
    return Vector3(
        a[0] * x + a[1] * y + a[2] * z,
        b[0] * x + b[1] * y + b[2] * z,
        c[0] * x + c[1] * y + c[2] * z,
    )


class Localization:
    """Names of the localization states."""

    UNINITIALIZED = "uninitialized"
    OK = "ok"
    DEGRADED = "degraded"
    LOST = "lost"


class _CompassYaw(NamedTuple):
    """The last compass reading as a map yaw: [s] stamp, [rad] yaw and its 1-sigma."""

    stamp: float
    yaw_rad: float
    std_rad: float


@dataclass
class _Counts:
    ignored: dict[str, int] = field(default_factory=dict)

    def ignore(self, reason: str) -> None:
        self.ignored[reason] = self.ignored.get(reason, 0) + 1


class StateEstimator:
    """Fuses IMU, lidar poses, GPS, compass and wheel odometry into one pose.

    Args:
        settings: the estimation and world sections; ``configure`` swaps them.
    """

    def __init__(self, settings: EstimatorSettings) -> None:
        self.settings = settings
        self.madgwick = MadgwickFilter(settings.estimation)
        self._counts = _Counts()
        self.geo: GeoFrame | None = None
        self._last_compass_yaw: _CompassYaw | None = None
        # each IMU's rotation to base_link as rows, None when aligned (found on first use)
        self._imu_rows: dict[str, _Rows | None] = {}
        est = settings.estimation
        self._q_poly = ProcessNoise(
            est.accel_noise_mps2**2, est.angular_accel_noise_radps2**2
        ).polynomial
        self.history = EventHistory(PoseUkf(settings.ukf), settings.history)
        self.beacon_map = BeaconMap(settings.beacons.gate_chi2)
        # the latest range to each known beacon: (stamp [s], range [m], std [m])
        self._ranges: dict[str, tuple[float, float, float]] = {}
        world = settings.world
        if world.datum_latitude_deg is not None and world.datum_longitude_deg is not None:
            self.geo = self._geo_frame(world.datum_latitude_deg, world.datum_longitude_deg)

    # --- configuration --------------------------------------------------------------------

    def configure(self, settings: EstimatorSettings) -> None:
        """Take new settings; the filter state, the IMU orientation and the map's
        geographic anchor are kept (a new datum or frame re-anchors the GPS conversion).

        Raises:
            GeoError: the new world section's datum cannot be projected (nothing changes).
        """
        geo = self._regeo(settings.world) if settings.world != self.settings.world else self.geo
        self.settings = settings
        self.geo = geo
        self._imu_rows = {}
        est = settings.estimation
        self._q_poly = ProcessNoise(
            est.accel_noise_mps2**2, est.angular_accel_noise_radps2**2
        ).polynomial
        self.madgwick.configure(est)
        self.beacon_map.gate_chi2 = settings.beacons.gate_chi2
        self.history.settings = settings.history
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

    def _regeo(self, world: WorldConfig) -> GeoFrame | None:
        """The geographic frame after a change of the world section: at the configured
        datum, or (without one) at the datum the first good fix set, in the new frame."""
        if world.datum_latitude_deg is not None and world.datum_longitude_deg is not None:
            return self._geo_frame(world.datum_latitude_deg, world.datum_longitude_deg, world=world)
        if self.geo is None:
            return None
        return self._geo_frame(*self.geo.datum, self.geo.datum_map_xy_m, world=world)

    def _geo_frame(
        self,
        latitude_deg: float,
        longitude_deg: float,
        at_xy: tuple[float, float] = (0.0, 0.0),
        *,
        world: WorldConfig | None = None,
    ) -> GeoFrame:
        world = world or self.settings.world
        return GeoFrame(
            latitude_deg,
            longitude_deg,
            map_rotation_rad=world.map_rotation_rad,
            zone=world.utm_zone,
            datum_map_xy_m=at_xy,
            max_distance_m=world.utm_threshold_m,
        )

    # --- inputs ---------------------------------------------------------------------------

    def add_imu(self, imu: Imu) -> bool:
        """Feed one IMU sample, turned into base_link by its mount, to Madgwick's filter;
        False if it was out of order."""
        rows = self._imu_rows.get(imu.device_id, _UNKNOWN)
        if rows is _UNKNOWN:
            rotation = self.settings.mounts.imu_rotation(imu.device_id)
            rows = None if rotation is None else tuple(tuple(map(float, r)) for r in rotation)
            self._imu_rows[imu.device_id] = rows
        if rows is not None:
            imu = dataclasses.replace(
                imu,
                gyro_radps=_rotate(rows, imu.gyro_radps),
                accel_mps2=_rotate(rows, imu.accel_mps2),
                mag_ut=None if imu.mag_ut is None else _rotate(rows, imu.mag_ut),
            )
        return self.madgwick.update(imu)

    def add_pose(self, pose: PoseMeasurement, now: float) -> Insert | None:
        """A scan-matched pose; starts the filter if nothing has yet."""
        cov = pose.covariance
        if not self.history.initialized:
            self._start(pose.stamp, pose.x_m, pose.y_m, pose.yaw_rad, cov)
            return None
        measurement = self._measurement(
            (Row.X, Row.Y, Row.YAW),
            [pose.x_m, pose.y_m, wrap_angle(pose.yaw_rad)],
            cov,
            pose.stamp,
        )
        gate = self.settings.estimation.lidar_gate_chi2
        return self._insert(Event(pose.stamp, pose.source, measurement, gate), now)

    def add_gps(self, fix: GpsFix, now: float) -> Insert | None:
        """A GNSS fix: ignored if stale, before a datum exists, or off the map."""
        world = self.settings.world
        if now - fix.stamp > world.coords_lifetime_s:
            self._counts.ignore("gps_stale")
            return None
        if self.geo is None and not self._take_datum(fix):
            return None
        assert self.geo is not None
        try:
            x, y = self.geo.to_map(fix.latitude_deg, fix.longitude_deg)
        except GeoError:
            self._counts.ignore("gps_off_map")
            return None
        variance = fix.horizontal_accuracy_m**2
        if not self.history.initialized:
            compass = self._last_compass_yaw
            if compass is not None and now - compass.stamp < 1.0:
                yaw, yaw_std = compass.yaw_rad, compass.std_rad
            else:
                yaw, yaw_std = 0.0, MAX_YAW_STD_RAD
            dx, dy = self._antenna_m(fix.device_id, yaw)
            x, y = x - dx, y - dy
            self._start(fix.stamp, x, y, yaw, np.diag([variance, variance, yaw_std**2]))
            return None
        # The fix is the antenna's; the centre is the lever arm behind it, turned by the
        # heading the filter predicts for the fix's time.
        dx, dy = self._antenna_m(fix.device_id, None, fix.stamp)
        x, y = x - dx, y - dy
        measurement = self._measurement(
            (Row.X, Row.Y), [x, y], np.diag([variance, variance]), fix.stamp
        )
        gate = self.settings.estimation.gps_gate_chi2
        return self._insert(Event(fix.stamp, "gps", measurement, gate), now)

    def _take_datum(self, fix: GpsFix) -> bool:
        """Anchor the map to ``fix`` if it is good enough; the robot keeps its map position."""
        if fix.horizontal_accuracy_m > self.settings.estimation.datum_max_accuracy_m:
            self._counts.ignore("gps_before_datum")
            return False
        at_xy = (0.0, 0.0)
        if self.history.initialized:
            estimate = self._predict(self.history.latest.x, fix.stamp)
            dx, dy = self._antenna_m(fix.device_id, float(estimate[TH]))
            at_xy = (float(estimate[X]) + dx, float(estimate[Y]) + dy)
        try:
            self.geo = self._geo_frame(fix.latitude_deg, fix.longitude_deg, at_xy)
        except GeoError:
            self._counts.ignore("gps_off_map")
            return False
        return True

    def add_compass(self, heading: CompassHeading, now: float) -> Insert | None:
        """A compass bearing, converted to map yaw (never used as a yaw unconverted)."""
        world = self.settings.world
        yaw = bearing_to_yaw(
            heading.bearing_deg,
            declination_deg=world.magnetic_declination_deg,
            magnetic=not heading.true_north,
            grid_convergence_rad=self.geo.grid_convergence_rad if self.geo else 0.0,
            map_rotation_rad=world.map_rotation_rad,
        )
        # the compass's forward axis is turned on the robot by its mount's yaw
        yaw = wrap_angle(yaw - self.settings.mounts.compass_yaw_rad(heading.device_id))
        std = math.radians(heading.accuracy_deg)
        self._last_compass_yaw = _CompassYaw(heading.stamp, yaw, std)
        if not self.history.initialized:
            return None
        measurement = self._measurement((Row.YAW,), [yaw], np.array([[std * std]]), heading.stamp)
        gate = self.settings.estimation.compass_gate_chi2
        return self._insert(Event(heading.stamp, "compass", measurement, gate), now)

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
        return self._insert(event, now)

    def add_beacon(self, seen: BeaconObservation, now: float) -> Insert | None:
        """A range and/or bearing to a beacon: fused if the beacon's place is known, else
        taken to learn its place (once the filter runs and if learning is on)."""
        beacons = self.settings.beacons
        place = beacons.known.get(seen.beacon_id)
        if place is None:
            if not beacons.learn:
                self._counts.ignore("beacon_unknown")
            elif not self.history.initialized:
                self._counts.ignore("beacon_before_start")
            else:
                self.beacon_map.observe(
                    seen.beacon_id,
                    self._pose_at(seen.stamp),
                    range_m=seen.range_m,
                    range_std_m=seen.range_std_m,
                    bearing_rad=seen.bearing_rad,
                    bearing_std_rad=seen.bearing_std_rad,
                )
            return None
        point = (place.x_m, place.y_m)
        if not self.history.initialized:
            if seen.has_range:
                self._ranges[seen.beacon_id] = (seen.stamp, seen.range_m, seen.range_std_m)
                self._start_from_ranges(seen.stamp)
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
        return self._insert(Event(seen.stamp, "beacon", measurement, beacons.gate_chi2), now)

    def _start_from_ranges(self, stamp: float) -> None:
        """Start the filter where the latest ranges to known beacons agree, once there are
        enough of them within RANGE_START_S of ``stamp`` (``_agreeing_place``); the heading
        from a recent compass reading, else unknown."""
        recent = [
            (self.settings.beacons.known[b], r, std)
            for b, (t, r, std) in self._ranges.items()
            if stamp - t <= RANGE_START_S
        ]
        # with a fourth beacon known, wait for it: three ranges fit a wrong place as well
        # as the right one when one of them is a reflection
        needed = min(max(len(self.settings.beacons.known), RANGE_START_BEACONS), 4)
        if len(recent) < needed:
            return
        points = np.array([[p.x_m, p.y_m] for p, _, _ in recent])
        ranges = np.array([r for _, r, _ in recent])
        stds = np.array([std for _, _, std in recent])
        found = _agreeing_place(points, ranges, stds)
        if found is None:
            return  # beacons in a line, or no place most ranges agree on: wait for more
        xy, cov = found
        compass = self._last_compass_yaw
        if compass is not None and stamp - compass.stamp < 1.0:
            yaw, yaw_std = compass.yaw_rad, compass.std_rad
        else:
            yaw, yaw_std = 0.0, MAX_YAW_STD_RAD
        cov3 = np.zeros((3, 3))
        cov3[:2, :2] = cov
        cov3[2, 2] = yaw_std**2
        self._start(stamp, float(xy[0]), float(xy[1]), yaw, cov3)
        self._ranges.clear()

    def beacon_places(self) -> tuple[BeaconPlace, ...]:
        """Every beacon with a place: the config's, then those learnt so far."""
        known = self.settings.beacons.known
        places = [BeaconPlace(b, p.x_m, p.y_m, 0.0, False, 0) for b, p in known.items()]
        for beacon_id, learnt in self.beacon_map.beacons.items():
            if learnt.mean is not None and beacon_id not in known:
                x, y = (float(v) for v in learnt.mean)
                places.append(BeaconPlace(beacon_id, x, y, learnt.std_m, True, learnt.observations))
        return tuple(places)

    def _pose_at(self, stamp: float) -> RobotPose:
        """The filter's pose at ``stamp`` (the state at or before it, predicted to it)."""
        then = self.history.at_or_before(stamp)
        f = transition_matrix(max(stamp - then.stamp, 0.0))
        x = f @ then.x
        cov = (f @ then.p @ f.T)[np.ix_((X, Y, TH), (X, Y, TH))]
        return RobotPose(float(x[X]), float(x[Y]), wrap_angle(float(x[TH])), cov)

    def set_pose(self, pose: InitialPose) -> None:
        """Restart the filter at a pose given by a person (forgets the events)."""
        var_xy = pose.std_xy_m**2
        cov = np.diag([var_xy, var_xy, pose.std_yaw_rad**2])
        self._start(pose.stamp, pose.x_m, pose.y_m, pose.yaw_rad, cov)

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
        if estimate is None:
            return Localization.UNINITIALIZED, math.inf, math.inf
        cov = estimate.covariance
        position_std = math.sqrt(max(_largest_eigenvalue(cov[0, 0], cov[0, 1], cov[1, 1]), 0.0))
        yaw_std = math.sqrt(max(float(cov[2, 2]), 0.0))
        est = self.settings.estimation
        if not position_std <= est.lost_position_std_m:  # a spread that is not a number too
            return Localization.LOST, position_std, yaw_std
        if position_std > est.degraded_position_std_m:
            return Localization.DEGRADED, position_std, yaw_std
        return Localization.OK, position_std, yaw_std

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
            "ignored": dict(self._counts.ignored),
            **self.madgwick.counters,
        }

    # --- helpers --------------------------------------------------------------------------

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

    def _insert(self, event: Event, now: float) -> Insert:
        counters = self.history.counters
        resets = counters.resets
        rejected = counters.rejected.get(event.source, 0)
        outcome = self.history.insert(event, now)
        if counters.resets > resets:
            # The filter reset itself from the last good state (a failed factorization).
            _log.warning(
                "ukf_reset", source=event.source, stamp=event.stamp, resets=counters.resets
            )
        if counters.rejected.get(event.source, 0) > rejected:
            _log.debug(
                "measurement_rejected",
                source=event.source,
                stamp=event.stamp,
                mahalanobis_sq=round(self.history.last_rejected_mahalanobis_sq, 2),
            )
        if outcome is Insert.TOO_OLD:
            _log.debug(
                "measurement_too_old", source=event.source, age_s=round(now - event.stamp, 3)
            )
        return outcome

    def _start(self, stamp: float, x: float, y: float, yaw: float, cov3: FloatArray) -> None:
        est = self.settings.estimation
        state = np.zeros(STATE_SIZE)
        state[X], state[Y], state[TH] = x, y, wrap_angle(yaw)
        variances = np.full(STATE_SIZE, est.initial_velocity_std_mps**2)
        variances[[4, 5]] = est.accel_noise_mps2**2
        variances[[VTH]] = 0.5**2
        variances[[8]] = est.angular_accel_noise_radps2**2
        p = np.diag(variances)
        p[np.ix_((X, Y, TH), (X, Y, TH))] = cov3
        p[TH, TH] = min(p[TH, TH], MAX_YAW_STD_RAD**2)
        self.history.initialize(stamp, state, p)

    def _predict(self, x: FloatArray, stamp: float) -> FloatArray:
        dt = max(stamp - self.history.latest.stamp, 0.0)
        predicted: FloatArray = transition_matrix(dt) @ x
        return predicted

    def _measurement(
        self,
        rows: tuple[Row, ...],
        z: list[float],
        r: FloatArray,
        stamp: float,
        *,
        points: list[tuple[float, float]] | None = None,
    ) -> Measurement:
        """The sensor's rows followed by the IMU window and the no-sliding constraint
        (``points`` [m]: the landmark of each of the sensor's rows, for ranges and bearings)."""
        est = self.settings.estimation
        window = self.madgwick.window_mean(stamp, est.imu_window_s)
        tail_rows: tuple[Row, ...] = ()
        tail_values: tuple[float, ...] = ()
        tail_variances: tuple[float, ...] = ()
        if window is not None:
            # The configured noise is that of the window mean (vibration and bias included).
            accel_var = est.imu_accel_std_mps2**2
            tail_rows = _IMU_ROWS
            tail_values = window[:3]
            tail_variances = (est.imu_yaw_rate_std_radps**2, accel_var, accel_var)
        if est.nonholonomic_std_mps is not None:
            tail_rows += (Row.VELOCITY_LEFT,)
            tail_values += (0.0,)
            tail_variances += (est.nonholonomic_std_mps**2,)
        k = len(rows)
        size = k + len(tail_rows)
        full = np.zeros((size, size))
        full[:k, :k] = r
        full[range(k, size), range(k, size)] = tail_variances
        landmarks = None
        if points is not None:
            landmarks = np.zeros((size, 2))
            landmarks[:k] = points
        return Measurement(
            rows=rows + tail_rows,
            z=np.array([*z, *tail_values]),
            r=full,
            gated_rows=k,
            points=landmarks,
        )


def _largest_eigenvalue(a: float, b: float, d: float) -> float:
    """The larger eigenvalue of the symmetric 2 x 2 matrix [[a, b], [b, d]] (closed form: at
    20 Hz on the event loop, a LAPACK call costs more than the rest of the estimate)."""
    half_trace = 0.5 * (float(a) + float(d))
    return half_trace + math.hypot(0.5 * (float(a) - float(d)), float(b))


def _agreeing_place(
    points_m: FloatArray, ranges_m: FloatArray, stds_m: FloatArray
) -> tuple[FloatArray, FloatArray] | None:
    """[m] the place (and its covariance) that all ranges, or all but one, agree on within
    RANGE_START_SIGMAS of their noise: each range is left out in turn (a reflection pulls a
    fit of all of them off the place, and three ranges fit a wrong place as well as the
    right one), and the fit that the most ranges agree with, then the closest, wins."""
    n = points_m.shape[0]
    best: tuple[int, float, FloatArray, FloatArray] | None = None
    subsets = [np.arange(n)] + ([np.delete(np.arange(n), k) for k in range(n)] if n > 3 else [])
    for subset in subsets:
        solved = _trilaterate(points_m[subset], ranges_m[subset], stds_m[subset])
        if solved is None:
            continue
        xy, cov, _ = solved
        misfit = (ranges_m - np.hypot(*(xy - points_m).T)) / stds_m
        agree = np.abs(misfit) <= RANGE_START_SIGMAS
        if not agree[subset].all() or agree.sum() < max(n - 1, RANGE_START_BEACONS):
            continue
        score = (int(agree.sum()), -float((misfit[agree] ** 2).sum()))
        if best is None or score > best[:2]:
            best = (*score, xy, cov)
    return None if best is None else (best[2], best[3])


def _trilaterate(
    points_m: FloatArray, ranges_m: FloatArray, stds_m: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """[m] the place whose distances to ``points_m`` best fit ``ranges_m`` (weighted least
    squares by Gauss-Newton from the points' centroid), its covariance, and each range's
    misfit in its own sigmas; None if the points are in a line or it does not settle."""
    if np.linalg.matrix_rank(points_m[1:] - points_m[0], tol=1e-3) < 2:
        return None
    weights = 1.0 / stds_m**2
    xy = points_m.mean(axis=0)
    for _ in range(30):
        offsets = xy - points_m
        distances = np.maximum(np.hypot(*offsets.T), 1e-6)
        jacobian = offsets / distances[:, None]
        normal = jacobian.T @ (weights[:, None] * jacobian)
        if np.linalg.cond(normal) > 1e9:
            return None
        cov = np.linalg.inv(normal)
        step = cov @ (jacobian.T @ (weights * (ranges_m - distances)))
        xy = xy + step
        if float(np.hypot(*step)) < 1e-4:
            distances = np.hypot(*(xy - points_m).T)
            return xy, cov, (ranges_m - distances) / stds_m
    return None
