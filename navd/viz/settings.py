"""The live view's settings and the recorder's."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from navd.config import NavdConfig, is_loopback, redacted
from navd.geometry import Footprint, SensorMounts
from navd.viz.recording_writer import WriterSettings
from navd.viz.viewer_gate import GateLimits

__all__ = ["RecorderSettings", "VizSettings"]

MB = 1_000_000


@dataclass(frozen=True, slots=True)
class VizSettings:
    """Where the view listens, how often each channel may send, and the robot it draws.

    Attributes:
        host, port: where the WebSocket server listens (they need a restart).
        viewers: how many viewers at once, and how far behind each may fall.
        map_period_s, scan_period_s, pose_period_s: [s] least time between two frames of
            the map, the scan, and the pose with the frame tree.
        log_level: lowest level of the log lines streamed.
        footprint: the robot's outline in base_link.
        lidar: the lidar's mount in base_link (the base_link -> laser frame).
        keep_out_zones: [m] polygons in the map frame the robot must not enter.
        zone_masks: the keep-out and speed masks' YAML files (None when not set).
        robot_name: the name the server gives itself.
        page_enabled, page_port: the operator page's HTTP server (they need a restart).
        commands: viewers may steer (goals, initial poses, velocities, cancels).
        untokened_commands: commands need no token (a loopback view only).
        teleop_enabled: operators may drive by hand.
        remote: the view listens beyond loopback (commands then need ``token``).
        token: ``tcp.token``, the secret a command from beyond loopback must carry.
        teleop_linear_mps, teleop_angular_radps: [m/s, rad/s] manual driving's top speeds
            (the page's joystick spans them).
    """

    host: str
    port: int
    viewers: GateLimits
    map_period_s: float
    scan_period_s: float
    pose_period_s: float
    log_level: Literal["debug", "info", "warning", "error"]
    footprint: Footprint
    mounts: SensorMounts
    keep_out_zones: tuple[tuple[tuple[float, float], ...], ...]
    zone_masks: tuple[str | None, str | None]
    robot_name: str
    page_enabled: bool
    page_port: int
    commands: bool
    untokened_commands: bool
    teleop_enabled: bool
    remote: bool
    token: str | None = field(repr=False)
    teleop_linear_mps: float
    teleop_angular_radps: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> VizSettings:
        """The settings the viz section describes, with the robot's shape and mounts."""
        viz = config.viz
        return cls(
            host=viz.host,
            port=viz.port,
            viewers=GateLimits(viz.max_viewers, viz.viewer_buffer_bytes),
            map_period_s=1.0 / viz.map_rate_hz,
            scan_period_s=1.0 / viz.scan_rate_hz,
            pose_period_s=1.0 / viz.pose_rate_hz,
            log_level=viz.log_level,
            footprint=Footprint.of(config.robot),
            mounts=SensorMounts.of(config.mounts, config.lidar),
            keep_out_zones=config.planning.keep_out_zones,
            zone_masks=(config.planning.keep_out_mask, config.planning.speed_mask),
            robot_name=config.robot.name,
            page_enabled=viz.page_enabled,
            page_port=viz.page_port,
            commands=viz.commands,
            untokened_commands=viz.untokened_commands,
            teleop_enabled=config.teleop.enabled,
            remote=not is_loopback(viz.host),
            token=config.tcp.token,
            teleop_linear_mps=config.teleop.max_linear_speed_mps,
            teleop_angular_radps=config.teleop.max_angular_speed_radps,
        )


@dataclass(frozen=True, slots=True)
class RecorderSettings:
    """The record section's values, and the config as a recording carries it.

    Attributes:
        enabled: record from start-up.
        writer: where and how files are written.
        map_period_s: [s] least time between two recorded maps.
        config_json: the whole config without its secrets (JSON).
    """

    enabled: bool
    writer: WriterSettings
    map_period_s: float
    config_json: bytes = field(repr=False)

    @classmethod
    def from_config(cls, config: NavdConfig) -> RecorderSettings:
        """The settings the record section describes; the token is never recorded."""
        record = config.record
        return cls(
            enabled=record.enabled,
            writer=WriterSettings(
                folder=Path(record.dir),
                max_file_bytes=int(record.max_file_mb * MB),
                budget_bytes=int(record.budget_mb * MB),
                flush_period_s=record.flush_period_s,
                mounts=SensorMounts.of(config.mounts, config.lidar),
            ),
            map_period_s=record.map_period_s,
            config_json=json.dumps(redacted(config)).encode(),
        )
