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

    Viewers may send goals, initial poses, velocities and cancels, each carrying a token:
    the run's own, which the operator page gets when a browser on this machine loads it,
    or ``tcp.token``. (A web page from elsewhere, open in a browser on the robot, can reach
    a loopback WebSocket too: the token is what keeps it from steering.) Foxglove's panels
    send no token: ``untokened_commands`` takes theirs on loopback. Listening beyond
    loopback must be asked for with ``allow_remote``; other machines then need
    ``tcp.token`` (without one the view is read-only to them).
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
        True,
        description="take goals, initial poses, velocities and cancels from viewers that carry "
        "a token: the run's own (the operator page on this machine has it) or tcp.token",
    )
    untokened_commands: bool = Field(
        False,
        description="also take commands without a token on loopback, as Foxglove's publish "
        "and teleop panels send them; any web page open in a browser on this machine (or "
        "tunnelled to it) could then steer the robot, through the safety gate",
    )
    page_enabled: bool = Field(True, **restart("serve the operator page over HTTP"))
    page_port: int = Field(
        8766, ge=0, le=65535, **restart("HTTP port of the operator page; 0 picks a free one")
    )
    max_viewers: int = Field(
        8,
        ge=1,
        le=256,
        description="live-view connections at once (Foxglove viewers and open pages); one more "
        "is answered 503",
    )
    viewer_buffer_bytes: int = Field(
        8_388_608,
        ge=1_048_576,
        le=268_435_456,
        description="[bytes] the most waiting to be sent to one viewer: one that falls further "
        "behind is disconnected (it may reconnect), so viewers hold at most max_viewers x this",
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
        remote = not is_loopback(self.host)
        if remote and not self.allow_remote:
            raise ValueError(
                f"viz.host {self.host!r} listens beyond loopback: set viz.allow_remote = true "
                f"to let other machines watch (their commands then need tcp.token), or keep "
                f'viz.host = "127.0.0.1"'
            )
        if remote and self.untokened_commands:
            raise ValueError(
                "viz.untokened_commands is for a view on loopback only; beyond it (viz.host "
                f"{self.host!r}) every command needs a token"
            )
        if self.port != 0 and self.port == self.page_port:
            raise ValueError(
                f"viz.port and viz.page_port are both {self.port}: give the page a port of its own"
            )
        return self
