"""The TCP server's settings, derived once from the tcp, safety, lidar and mounts sections;
and the config as control clients may read it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from navd.config import NavdConfig, redacted
from navd.geometry import SensorMounts
from navd.lifecycle.messages import DeviceKind

__all__ = [
    "STATUS_FRAME_BYTES",
    "ConnectionLimits",
    "SensorPacing",
    "TcpSettings",
    "readable_config",
]

STATUS_FRAME_BYTES = 4096  # [bytes] a status frame, for the output bound of a slow reader


@dataclass(frozen=True, slots=True)
class ConnectionLimits:
    """What one connection is bounded by (every open connection holds its own copy).

    Attributes:
        max_line_bytes: [bytes] longest accepted line.
        write_high_bytes: [bytes] output buffered beyond this drops droppable frames.
        slow_reader_s: [s] droppable frames dropped without a break for this long close it.
    """

    max_line_bytes: int
    write_high_bytes: int
    slow_reader_s: float


@dataclass(frozen=True, slots=True)
class SensorPacing:
    """How a sensor connection is read.

    Attributes:
        coalesce_s: [s] pause after reading a fast stream, so it is read in batches.
    """

    coalesce_s: float


@dataclass(frozen=True, slots=True)
class TcpSettings:
    """What the server listens with and how it treats its clients.

    Attributes:
        host, port, token: where it listens and the shared secret (they need a restart).
        allow_privileged_changes: control clients may change privileged keys (a restart).
        max_clients: [clients] most clients connected at once (after their hello).
        max_control_clients: [clients] most of them control clients (the rest: sensors).
        max_pending: [connections] most connections waiting to say hello.
        control_idle_timeout_s: [s] a control client silent and unsubscribed this long is
            disconnected.
        sensor_idle_timeout_s: [s] a sensor that sends nothing this long is disconnected.
        handshake_timeout_s: [s] a new connection has this long to say hello.
        stale_after_s: [s] per sensor kind, silence that makes a device stale.
        lockstep_timeout_s: [s] real time a clock step waits for the lines it was promised.
        robot_name: the name status frames carry.
        teleop_enabled: control clients may drive by hand (``teleop.enabled``).
        mounts: the sensors' mounts: which device ids may connect, which ROS frame_ids
            their frames may name.
        connection: what every connection is bounded by.
        pacing: how sensor connections are read.
    """

    host: str
    port: int
    token: str | None = field(repr=False)
    allow_privileged_changes: bool
    max_clients: int
    max_control_clients: int
    max_pending: int
    control_idle_timeout_s: float
    sensor_idle_timeout_s: float
    handshake_timeout_s: float
    stale_after_s: tuple[tuple[DeviceKind, float], ...]
    lockstep_timeout_s: float
    robot_name: str
    teleop_enabled: bool
    mounts: SensorMounts
    connection: ConnectionLimits
    pacing: SensorPacing

    @classmethod
    def from_config(cls, config: NavdConfig) -> TcpSettings:
        """The settings the tcp section describes (with the lifecycle's lockstep timeout and
        the robot's name)."""
        tcp = config.tcp
        return cls(
            host=tcp.host,
            port=tcp.port,
            token=tcp.token,
            allow_privileged_changes=tcp.allow_privileged_changes,
            max_clients=tcp.max_clients,
            max_control_clients=tcp.max_control_clients,
            max_pending=tcp.max_pending,
            control_idle_timeout_s=tcp.control_idle_timeout_s,
            sensor_idle_timeout_s=tcp.sensor_idle_timeout_s,
            handshake_timeout_s=tcp.handshake_timeout_s,
            stale_after_s=(
                (DeviceKind.LIDAR, tcp.lidar_timeout_s),
                (DeviceKind.IMU, tcp.imu_timeout_s),
                (DeviceKind.GPS, tcp.gps_timeout_s),
                (DeviceKind.COMPASS, tcp.compass_timeout_s),
                (DeviceKind.BEACON, tcp.beacon_timeout_s),
                (DeviceKind.WHEEL_ODOMETRY, tcp.wheel_odometry_timeout_s),
                (DeviceKind.RANGE, tcp.range_timeout_s),
                (DeviceKind.CONTACT, tcp.contact_timeout_s),
                (DeviceKind.POINTS, tcp.points_timeout_s),
                (DeviceKind.BATTERY, tcp.battery_timeout_s),
            ),
            lockstep_timeout_s=config.lifecycle.lockstep_timeout_s,
            robot_name=config.robot.name,
            teleop_enabled=config.teleop.enabled,
            mounts=SensorMounts.of(config.mounts, config.lidar),
            connection=ConnectionLimits(
                tcp.max_line_bytes,
                tcp.status_queue * STATUS_FRAME_BYTES,
                tcp.slow_reader_timeout_s,
            ),
            pacing=SensorPacing(tcp.read_coalesce_ms / 1e3),
        )


def readable_config(config: NavdConfig) -> dict[str, Any]:
    """The config in force as ``config_get`` answers it: plain data, secrets redacted."""
    return redacted(config)
