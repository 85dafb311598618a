"""The live view: what navd thinks, streamed to Foxglove (or Lichtblick) and to the operator
page while it runs."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from navd.config.fields import Section, is_loopback, restart

__all__ = ["VizConfig"]


class VizConfig(Section):
    """The live view: a Foxglove WebSocket stream of the map, scan, frames, pose, route, goal,
    status and log, and the operator page served over HTTP. Nothing is encoded for a channel
    nobody subscribes to.

    Viewers may send goals, initial poses, velocities and cancels. On loopback (the default)
    only this machine can connect, so they are taken as they come; listening beyond
    loopback must be asked for with ``allow_remote``, and then every command must carry
    ``tcp.token`` (a view without it is read-only). The SDK does not tell the address a
    viewer connects from, so beyond loopback the token is needed from this machine too.
    """

    enabled: bool = Field(True, **restart("serve the live view"))
    host: str = Field(
        "127.0.0.1",
        min_length=1,
        **restart("address the live view listens on (loopback: only this machine can watch)"),
    )
    port: int = Field(
        8765, ge=0, le=65535, **restart("WebSocket port (Foxglove's default); 0 picks a free one")
    )
    allow_remote: bool = Field(
        False,
        **restart(
            "let viz.host be an address beyond loopback: other machines may watch, and may "
            "command only with tcp.token"
        ),
    )
    commands: bool = Field(
        True, description="take goals, initial poses, velocities and cancels from viewers"
    )
    page_enabled: bool = Field(True, **restart("serve the operator page over HTTP"))
    page_port: int = Field(
        8766, ge=0, le=65535, **restart("HTTP port of the operator page; 0 picks a free one")
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

    @model_validator(mode="after")
    def _remote_on_purpose(self) -> VizConfig:
        if not is_loopback(self.host) and not self.allow_remote:
            raise ValueError(
                f"viz.host {self.host!r} listens beyond loopback: set viz.allow_remote = true "
                f"to let other machines watch (their commands then need tcp.token), or keep "
                f'viz.host = "127.0.0.1"'
            )
        return self
