"""How the simulator connects and what its sensors are like."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

__all__ = ["SimSettings"]


@dataclass(frozen=True, slots=True)
class SimSettings:
    """How the simulator connects and what its sensors are like.

    Attributes:
        host, port: the daemon's TCP server; token: its ``tcp.token`` when it has one.
        tty_link: path of the symlink to the chassis end of the pseudo-terminal.
        lidar_beams, lidar_rate_hz, lidar_noise_m, lidar_max_range_m: each 2D lidar (0 Hz:
            none).
        lidar_fov_rad: [rad] each lidar's field of view, centred on its forward axis.
        imu_rate_hz, gyro_noise_radps, gyro_bias_radps, accel_noise_mps2: the IMU (0 Hz: none).
        gps_rate_hz, gps_noise_m: a GNSS receiver, streaming only when the daemon's config
            has a datum (``world.datum_latitude_deg``/``longitude_deg``, at map (0, 0)).
        compass_rate_hz, compass_noise_deg: a magnetic compass (0 Hz: none); it reports
            magnetic bearings, so the daemon's ``world.magnetic_declination_deg`` applies.
        beacon_rate_hz: observations per second of the world's beacons, one beacon each in
            turn (0 Hz, or a world without beacons: none); beacon_mode: what each measures;
            beacon_range_noise_m, beacon_bearing_noise_rad: their 1-sigma noise;
            beacon_max_range_m: farther beacons are not seen.
        range_rate_hz, range_fov_deg, range_max_m, range_noise_m: each range sensor the
            config mounts (``mounts.ranges``), an ultrasonic one: it hears the glass too.
        contact_rate_hz: each bumper and cliff sensor (``mounts.contacts``; a name starting
            with "cliff" is a cliff sensor) says its state this often.
        depth_rate_hz, depth_fov_deg, depth_rays: each depth camera (``mounts.depth``): a
            fan of rays across its horizontal view, at heights through its band.
        battery_rate_hz, battery_wh, battery_idle_w, battery_drive_w: a battery (0 Hz:
            none): it drains at idle power, and more in proportion to the speed.
        physics_rate_hz: world steps per second (in lockstep: clock steps per second; sensor
            rates are rounded to whole steps).
        feedback_rate_hz: encoder lines per second (0: none).
        seed: seeds every noise source.
        clock: "real" or "lockstep" (the simulator drives the daemon's simulated clock).
    """

    host: str = "127.0.0.1"
    port: int = 0
    token: str | None = None
    tty_link: Path = Path("/tmp/navd-sim-tty")
    lidar_beams: int = 360
    lidar_rate_hz: float = 10.0
    lidar_noise_m: float = 0.01
    lidar_max_range_m: float = 12.0
    lidar_fov_rad: float = 2.0 * math.pi
    imu_rate_hz: float = 100.0
    gyro_noise_radps: float = 0.002
    gyro_bias_radps: float = 0.003
    accel_noise_mps2: float = 0.05
    gps_rate_hz: float = 5.0
    gps_noise_m: float = 1.0
    compass_rate_hz: float = 10.0
    compass_noise_deg: float = 2.0
    beacon_rate_hz: float = 10.0
    beacon_mode: Literal["range", "bearing", "both"] = "range"
    beacon_range_noise_m: float = 0.1
    beacon_bearing_noise_rad: float = 0.03
    beacon_max_range_m: float = 50.0
    range_rate_hz: float = 10.0
    range_fov_deg: float = 15.0
    range_max_m: float = 4.0
    range_noise_m: float = 0.01
    contact_rate_hz: float = 50.0
    depth_rate_hz: float = 5.0
    depth_fov_deg: float = 70.0
    depth_rays: int = 48
    battery_rate_hz: float = 0.0
    battery_wh: float = 50.0
    battery_idle_w: float = 5.0
    battery_drive_w: float = 20.0
    physics_rate_hz: float = 100.0
    feedback_rate_hz: float = 20.0
    seed: int = 0
    clock: Literal["real", "lockstep"] = "real"
