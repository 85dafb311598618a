"""What the simulated sensors measure: typed frames from the robot's true state, with noise.

A 2D lidar (ray cast against the world and its movers, Gaussian range noise), an IMU (gyro
with bias and noise, accelerations of the true motion plus gravity), a GNSS receiver (only
when the daemon has a datum: it is placed at map (0, 0)) and a magnetic compass (through the
daemon's declination and grid convergence, the inverse of its conversion). Pure: every
frame is a function of the state and the seeded noise, stamped with the time given.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from navd.config import NavdConfig
from navd.estimation import GeoFrame
from navd.geometry import Pose2, SensorMounts
from navd.sim._sim_kernels import cast_rays
from navd.sim.body_sensors import BodySensors
from navd.sim.physics import SimRobot
from navd.sim.settings import SimSettings
from navd.wire import BeaconFrame, FixFrame, HeadingFrame, ImuFrame, Role, ScanFrame, SensorFrame

__all__ = ["GRAVITY_MPS2", "SensorModels", "SimSensor"]

GRAVITY_MPS2 = 9.80665
LIDAR_RANGE_MIN_M = 0.05


@dataclass
class SimSensor:
    """One simulated sensor: its role, device id, rate and frames, and whether a scenario
    has it plugged in.

    Attributes:
        role, device_id: what it says in its hello.
        rate_hz: [Hz] frames per second.
        frame: the frame at a time [s] (None: nothing to say then).
        plugged: False while a scenario has it unplugged (None: always plugged).
        silent: True while a scenario has it connected but sending nothing (a hung driver).
        last_sent_s: [s] simulation time it last sent a frame.
    """

    role: Role
    device_id: str
    rate_hz: float
    frame: Callable[[float], SensorFrame | None]
    plugged: Callable[[], bool] | None = None
    silent: Callable[[], bool] | None = None
    last_sent_s: float = -math.inf

    def is_plugged(self) -> bool:
        """False while a scenario has it unplugged."""
        return self.plugged is None or self.plugged()

    def is_silent(self) -> bool:
        """True while a scenario keeps it connected but quiet."""
        return self.silent is not None and self.silent()


class SensorModels:
    """The sensors of ``robot``, as ``settings`` describes them.

    Args:
        robot: the simulated robot (read, never moved).
        config: the daemon's config (the lidar mount, the datum, the declination).
        settings: rates, noises, seed.
    """

    def __init__(self, robot: SimRobot, config: NavdConfig, settings: SimSettings) -> None:
        self.robot = robot
        self.config = config
        self.settings = settings
        self._rng = np.random.default_rng(settings.seed)
        world = config.world
        self.geo: GeoFrame | None = None
        if world.datum_latitude_deg is not None and world.datum_longitude_deg is not None:
            self.geo = GeoFrame(
                world.datum_latitude_deg,
                world.datum_longitude_deg,
                map_rotation_rad=world.map_rotation_rad,
                zone=world.utm_zone,
                max_distance_m=world.utm_threshold_m,
            )
        # Scenario controls: an unplugged sensor closes its connection until plugged back;
        # a silent one stays connected and sends nothing.
        self.lidar_plugged = True
        self.gps_plugged = True
        self.imu_plugged = True
        self.lidar_silent = False
        self.imu_silent = False
        self._sensors: list[SimSensor] | None = None
        self._next_beacon = 0  # the beacon sensor's turn
        # Where the first listed IMU, GNSS antenna and compass sit (their mounts' inverse).
        mounts = SensorMounts.of(config.mounts, config.lidar)
        self._imu_to_base = mounts.imu_rotation(next(iter(config.mounts.imus), ""))
        self._antenna_m = mounts.gps_offset_m(next(iter(config.mounts.gps), ""))
        self._compass_yaw_rad = mounts.compass_yaw_rad(next(iter(config.mounts.compasses), ""))

    def sensors(self) -> list[SimSensor]:
        """The sensors this robot has (the same objects on every call)."""
        if self._sensors is None:
            self._sensors = self._make_sensors()
        return self._sensors

    def sensor(self, role: Role) -> SimSensor:
        """The sensor of ``role``.

        Raises:
            KeyError: the robot has none.
        """
        for sensor in self.sensors():
            if sensor.role == role:
                return sensor
        raise KeyError(f"the simulated robot has no {role}")

    def _make_sensors(self) -> list[SimSensor]:
        s, mounts = self.settings, self.config.mounts
        # One lidar per mount the config lists (the lidar section's single one without).
        lidars = (list(mounts.lidars) or ["sim-lidar"]) if s.lidar_rate_hz > 0 else []
        sensors = [
            SimSensor(
                "lidar",
                device_id,
                s.lidar_rate_hz,
                functools.partial(self.scan, lidar=device_id),
                lambda: self.lidar_plugged,
                lambda: self.lidar_silent,
            )
            for device_id in lidars
        ]
        if s.imu_rate_hz > 0:
            sensors.append(
                SimSensor(
                    "imu",
                    next(iter(mounts.imus), "sim-imu"),
                    s.imu_rate_hz,
                    self.imu,
                    lambda: self.imu_plugged,
                    lambda: self.imu_silent,
                )
            )
        if s.gps_rate_hz > 0 and self.geo is not None:
            gps = next(iter(mounts.gps), "sim-gps")
            sensors.append(SimSensor("gps", gps, s.gps_rate_hz, self.fix, lambda: self.gps_plugged))
        if s.compass_rate_hz > 0:
            compass = next(iter(mounts.compasses), "sim-compass")
            sensors.append(SimSensor("compass", compass, s.compass_rate_hz, self.heading))
        if s.beacon_rate_hz > 0 and self.robot.world.beacons:
            sensors.append(SimSensor("beacon", "sim-beacons", s.beacon_rate_hz, self.beacon))
        body = BodySensors(self.robot, self.config, s, self._rng)
        sensors += [SimSensor(*source) for source in body.frames()]
        return sensors

    def scan(self, now: float, lidar: str = "sim-lidar") -> ScanFrame:
        """A sweep of ``lidar_fov_rad`` centred on the lidar's forward axis, from its mount
        (``mounts.lidars`` or the lidar section), with range noise; no return is null."""
        s = self.settings
        mount = self.config.mounts.lidars.get(lidar) or self.config.lidar
        b = self.robot.body
        where = Pose2(b.x_m, b.y_m, b.yaw_rad).compose(Pose2(mount.x_m, mount.y_m, 0.0))
        fov = min(s.lidar_fov_rad, 2.0 * math.pi)
        increment = fov / s.lidar_beams
        first = -fov / 2.0 if fov < 2.0 * math.pi else -math.pi
        local = first + increment * np.arange(s.lidar_beams)
        # upside down, the lidar's own bearings run clockwise in the robot's frame
        flip = -1.0 if mount.upside_down else 1.0
        angles = (flip * local + b.yaw_rad + mount.yaw_rad).astype(np.float64)
        w = self.robot.world
        ranges = cast_rays(
            w.grid,
            w.origin_x_m,
            w.origin_y_m,
            w.resolution_m,
            where.x,
            where.y,
            angles,
            s.lidar_max_range_m,
            self.robot.discs(),
        )
        ranges = ranges + self._rng.normal(0.0, s.lidar_noise_m, ranges.size)
        return ScanFrame.model_construct(
            stamp=now,
            angle_min=first,
            angle_increment=increment,
            range_min=LIDAR_RANGE_MIN_M,
            range_max=s.lidar_max_range_m,
            ranges=[round(float(r), 4) if math.isfinite(r) else None for r in ranges],
        )

    def imu(self, now: float) -> ImuFrame:
        """Gyro (bias and noise) and accelerometer (true motion, gravity, noise)."""
        s = self.settings
        noise = self._rng.normal(0.0, 1.0, 6)
        ax, ay = self.robot.last_accel
        gyro = np.array(
            [
                s.gyro_noise_radps * noise[0],
                s.gyro_noise_radps * noise[1],
                self.robot.body.angular_radps + s.gyro_bias_radps + s.gyro_noise_radps * noise[2],
            ]
        )
        accel = np.array(
            [
                ax + s.accel_noise_mps2 * noise[3],
                ay + s.accel_noise_mps2 * noise[4],
                GRAVITY_MPS2 + s.accel_noise_mps2 * noise[5],
            ]
        )
        if self._imu_to_base is not None:  # what an IMU turned on its mount measures
            gyro, accel = self._imu_to_base.T @ gyro, self._imu_to_base.T @ accel
        return ImuFrame(
            stamp=now,
            angular_velocity=(float(gyro[0]), float(gyro[1]), float(gyro[2])),
            linear_acceleration=(float(accel[0]), float(accel[1]), float(accel[2])),
        )

    def fix(self, now: float) -> FixFrame:
        """The body's position in WGS84, with Gaussian noise of ``gps_noise_m``."""
        assert self.geo is not None, "a GNSS receiver needs the daemon's datum"
        sigma = self.settings.gps_noise_m
        dx, dy = self._rng.normal(0.0, sigma, 2)
        b = self.robot.body
        (ax, ay), c, s = self._antenna_m, math.cos(b.yaw_rad), math.sin(b.yaw_rad)
        x, y = b.x_m + c * ax - s * ay, b.y_m + s * ax + c * ay
        lat, lon = self.geo.to_wgs84(x + dx, y + dy)
        return FixFrame(
            stamp=now,
            latitude=float(lat),
            longitude=float(lon),
            altitude=0.0,
            horizontal_accuracy=sigma,
        )

    def beacon(self, now: float) -> BeaconFrame | None:
        """The next beacon in turn within range: its range and/or bearing from the body's
        centre, with Gaussian noise (None when none is in range)."""
        s, b = self.settings, self.robot.body
        beacons = self.robot.world.beacons
        for _ in range(len(beacons)):
            beacon_id, x, y = beacons[self._next_beacon % len(beacons)]
            self._next_beacon += 1
            distance = math.hypot(x - b.x_m, y - b.y_m)
            if distance > s.beacon_max_range_m:
                continue
            range_m = bearing = None
            if s.beacon_mode in ("range", "both"):
                range_m = max(distance + float(self._rng.normal(0.0, s.beacon_range_noise_m)), 0.0)
            if s.beacon_mode in ("bearing", "both"):
                true_bearing = math.atan2(y - b.y_m, x - b.x_m) - b.yaw_rad
                noisy = true_bearing + float(self._rng.normal(0.0, s.beacon_bearing_noise_rad))
                bearing = math.remainder(noisy, math.tau)
            return BeaconFrame(
                stamp=now,
                beacon=beacon_id,
                range_m=range_m,
                range_std_m=s.beacon_range_noise_m,
                bearing_rad=bearing,
                bearing_std_rad=s.beacon_bearing_noise_rad,
            )
        return None

    def heading(self, now: float) -> HeadingFrame:
        """A magnetic bearing of the true yaw: the inverse of the daemon's conversion."""
        world = self.config.world
        convergence = self.geo.grid_convergence_rad if self.geo is not None else 0.0
        enu_yaw = self.robot.body.yaw_rad + self._compass_yaw_rad + world.map_rotation_rad
        enu_yaw += convergence
        true_bearing = 90.0 - math.degrees(enu_yaw)
        noise = self._rng.normal(0.0, self.settings.compass_noise_deg)
        magnetic = (true_bearing - world.magnetic_declination_deg + noise) % 360.0
        return HeadingFrame(
            stamp=now,
            bearing_deg=float(magnetic) if magnetic < 360.0 else 0.0,
            accuracy_deg=self.settings.compass_noise_deg,
        )
