"""Synthetic drives with known truth for the estimator: a figure-eight and its sensor data.

The robot drives a figure-eight (a lemniscate of Gerono) as a differential drive would:
its heading is always its direction of travel. Sensors are sampled from the truth with
seeded noise: IMU (gyro bias and noise, accelerometer noise), scan-matched lidar poses,
GPS fixes around a datum, compass bearings and wheel odometry. Each message gets a
measurement stamp and an arrival time, so delivery can be delayed per sensor.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from navd.estimation import GRAVITY_MPS2, GeoFrame, StateEstimator
from navd.geometry import wrap_angle
from navd.lifecycle.messages import (
    BeaconObservation,
    CompassHeading,
    GpsFix,
    Imu,
    Message,
    PoseEstimate,
    PoseMeasurement,
    Vector3,
    WheelOdometry,
)

__all__ = ["FigureEight", "SensorSuite", "SpinInPlace", "TruePath", "TruthPose", "drive", "replay"]


@dataclass(frozen=True, slots=True)
class TruthPose:
    """The true motion at a time: position [m], heading [rad], velocity [m/s], accel [m/s²]."""

    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    ax: float
    ay: float
    yaw_rate: float


@dataclass(frozen=True, slots=True)
class FigureEight:
    """x = a sin(wt), y = (a/2) sin(2wt): a figure-eight of width 2a [m] every ``period_s``."""

    half_width_m: float = 5.0
    period_s: float = 60.0

    def at(self, t: float) -> TruthPose:
        """The true motion at ``t`` [s]."""
        a = self.half_width_m
        w = 2.0 * math.pi / self.period_s
        s1, c1 = math.sin(w * t), math.cos(w * t)
        s2, c2 = math.sin(2 * w * t), math.cos(2 * w * t)
        x, y = a * s1, 0.5 * a * s2
        vx, vy = a * w * c1, a * w * c2
        ax, ay = -a * w * w * s1, -2.0 * a * w * w * s2
        speed_sq = vx * vx + vy * vy
        yaw = math.atan2(vy, vx)
        yaw_rate = (vx * ay - vy * ax) / speed_sq
        return TruthPose(x, y, yaw, vx, vy, ax, ay, yaw_rate)


@dataclass(frozen=True, slots=True)
class SpinInPlace:
    """Turning on the spot at (0, 0) at ``yaw_rate_radps``: the heading changes, the centre
    does not (what a GNSS antenna off the centre gets wrong)."""

    yaw_rate_radps: float = 0.5

    def at(self, t: float) -> TruthPose:
        """The true motion at ``t`` [s]."""
        w = self.yaw_rate_radps
        return TruthPose(0.0, 0.0, wrap_angle(w * t), 0.0, 0.0, 0.0, 0.0, w)


class TruePath(Protocol):
    """A true motion: its pose, velocity and acceleration at any time."""

    def at(self, t: float) -> TruthPose: ...


@dataclass(frozen=True, slots=True)
class SensorSuite:
    """Which sensors run, how fast, how noisy and how late.

    Rates in Hz (0: sensor absent), noise as 1-sigma, delays in seconds between measurement
    and arrival.
    """

    imu_hz: float = 1000.0
    gyro_noise_radps: float = 0.003
    gyro_bias_radps: float = 0.004
    accel_noise_mps2: float = 0.05
    lidar_hz: float = 10.0
    lidar_xy_std_m: float = 0.02
    lidar_yaw_std_rad: float = math.radians(1.0)
    lidar_delay_s: float = 0.0
    gps_hz: float = 0.0
    gps_std_m: float = 1.5
    compass_hz: float = 0.0
    compass_std_deg: float = 3.0
    wheel_hz: float = 0.0
    wheel_linear_std_mps: float = 0.02
    wheel_angular_std_radps: float = 0.02
    datum: tuple[float, float] = (52.52, 13.405)
    gps_antenna_m: tuple[float, float] = (0.0, 0.0)  # (x, y) in base_link
    seed: int = 7


def _times(rate_hz: float, duration_s: float, offset_s: float) -> Iterator[float]:
    if rate_hz <= 0.0:
        return
    n = int(duration_s * rate_hz)
    for i in range(n):
        yield offset_s + i / rate_hz


def drive(
    path: TruePath,
    suite: SensorSuite,
    duration_s: float,
    *,
    lidar_windows: Sequence[tuple[float, float]] | None = None,
    gps_windows: Sequence[tuple[float, float]] | None = None,
) -> list[Message]:
    """Sensor messages of a drive, in arrival order.

    Args:
        path: the true motion.
        suite: sensors and noise.
        duration_s: [s] length of the drive.
        lidar_windows, gps_windows: [s] (start, end) spans when that sensor reports;
            None: always.
    """
    rng = np.random.default_rng(suite.seed)
    geo = GeoFrame(
        suite.datum[0], suite.datum[1], map_rotation_rad=0.0, zone=None, max_distance_m=1e5
    )
    messages: list[Message] = []

    def inside(windows: Sequence[tuple[float, float]] | None, t: float) -> bool:
        return windows is None or any(start <= t < end for start, end in windows)

    for t in _times(suite.imu_hz, duration_s, 0.0):
        truth = path.at(t)
        cos, sin = math.cos(truth.yaw), math.sin(truth.yaw)
        gyro_z = truth.yaw_rate + suite.gyro_bias_radps + rng.normal(0, suite.gyro_noise_radps)
        gx, gy = rng.normal(0, suite.gyro_noise_radps, 2)
        a_fwd = cos * truth.ax + sin * truth.ay
        a_left = -sin * truth.ax + cos * truth.ay
        n = rng.normal(0, suite.accel_noise_mps2, 3)
        messages.append(
            Imu(
                stamp=t,
                received=t,
                device_id="imu",
                gyro_radps=Vector3(float(gx), float(gy), gyro_z),
                accel_mps2=Vector3(a_fwd + n[0], a_left + n[1], GRAVITY_MPS2 + n[2]),
            )
        )
    for t in _times(suite.lidar_hz, duration_s, 0.05):
        if not inside(lidar_windows, t):
            continue
        truth = path.at(t)
        nx, ny = rng.normal(0, suite.lidar_xy_std_m, 2)
        nyaw = rng.normal(0, suite.lidar_yaw_std_rad)
        var_xy, var_yaw = suite.lidar_xy_std_m**2, suite.lidar_yaw_std_rad**2
        messages.append(
            PoseMeasurement(
                stamp=t,
                received=t + suite.lidar_delay_s,
                source="lidar",
                x_m=truth.x + nx,
                y_m=truth.y + ny,
                yaw_rad=wrap_angle(truth.yaw + nyaw),
                covariance=np.diag([var_xy, var_xy, var_yaw]),
            )
        )
    for t in _times(suite.gps_hz, duration_s, 0.02):
        if not inside(gps_windows, t):
            continue
        truth = path.at(t)
        nx, ny = rng.normal(0, suite.gps_std_m, 2)
        (ox, oy), c, s = suite.gps_antenna_m, math.cos(truth.yaw), math.sin(truth.yaw)
        antenna_x, antenna_y = truth.x + c * ox - s * oy, truth.y + s * ox + c * oy
        lat, lon = geo.to_wgs84(antenna_x + nx, antenna_y + ny)
        messages.append(
            GpsFix(
                stamp=t,
                received=t,
                device_id="gps",
                latitude_deg=lat,
                longitude_deg=lon,
                altitude_m=40.0,
                horizontal_accuracy_m=suite.gps_std_m,
            )
        )
    for t in _times(suite.compass_hz, duration_s, 0.03):
        truth = path.at(t)
        # The compass reports true bearings here (clockwise from north); the grid
        # convergence at the datum turns the map's yaw into a true direction.
        true_yaw = truth.yaw + geo.grid_convergence_rad
        bearing = (90.0 - math.degrees(true_yaw) + rng.normal(0, suite.compass_std_deg)) % 360.0
        messages.append(
            CompassHeading(
                stamp=t,
                received=t,
                device_id="compass",
                bearing_deg=bearing,
                accuracy_deg=suite.compass_std_deg,
                true_north=True,
            )
        )
    for t in _times(suite.wheel_hz, duration_s, 0.01):
        truth = path.at(t)
        messages.append(
            WheelOdometry(
                stamp=t,
                received=t,
                device_id="wheels",
                linear_mps=math.hypot(truth.vx, truth.vy)
                + rng.normal(0, suite.wheel_linear_std_mps),
                angular_radps=truth.yaw_rate + rng.normal(0, suite.wheel_angular_std_radps),
            )
        )
    messages.sort(key=lambda m: (m.received, m.stamp))
    return messages


def replay(
    estimator: StateEstimator, messages: Iterable[Message], *, estimate_hz: float = 20.0
) -> list[PoseEstimate]:
    """Feed ``messages`` in arrival order; sample the estimate at ``estimate_hz``.

    The clock is each message's arrival time; an estimate is taken whenever the clock
    passes the next sampling time.
    """
    estimates: list[PoseEstimate] = []
    period = 1.0 / estimate_hz
    next_sample = 0.0
    for message in messages:
        now = message.received
        while now >= next_sample:
            estimator.advance(next_sample)
            estimate = estimator.estimate(next_sample)
            if estimate is not None:
                estimates.append(estimate)
            next_sample += period
        if isinstance(message, Imu):
            estimator.add_imu(message)
        elif isinstance(message, PoseMeasurement):
            estimator.add_pose(message, now)
        elif isinstance(message, GpsFix):
            estimator.add_gps(message, now)
        elif isinstance(message, CompassHeading):
            estimator.add_compass(message, now)
        elif isinstance(message, WheelOdometry):
            estimator.add_wheel_odometry(message, now)
        elif isinstance(message, BeaconObservation):
            estimator.add_beacon(message, now)
    return estimates
