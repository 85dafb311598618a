"""The live view: what navd thinks, streamed to Foxglove (or Lichtblick) while it runs."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from navd.config.fields import Section, restart

__all__ = ["VizConfig"]


class VizConfig(Section):
    """The live view: a Foxglove WebSocket stream of the map, scan, frames, pose, route, goal,
    status and log. Nothing is encoded for a channel nobody subscribes to."""

    enabled: bool = Field(True, **restart("serve the live view"))
    host: str = Field(
        "127.0.0.1",
        min_length=1,
        **restart("address the live view listens on (loopback: only this machine can watch)"),
    )
    port: int = Field(
        8765, ge=0, le=65535, **restart("WebSocket port (Foxglove's default); 0 picks a free one")
    )
    map_rate_hz: float = Field(
        1.0, gt=0, le=10, description="[Hz] most map frames a second (the map is the largest)"
    )
    scan_rate_hz: float = Field(10.0, gt=0, le=100, description="[Hz] most scans a second")
    pose_rate_hz: float = Field(
        20.0, gt=0, le=200, description="[Hz] most pose and frame-tree updates a second"
    )
    log_level: Literal["debug", "info", "warning", "error"] = Field(
        "info", description="lowest level of the log lines streamed to the view"
    )
