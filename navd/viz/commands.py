"""Commands from viewers: what a Foxglove client or the operator page publishes, read as the
control requests a TCP control client sends.

A viewer advertises a channel (JSON encoding) and publishes on it. Topics understood:

- ``/navd/command``: navd's own control frames (see docs/protocol.md), of the types
  ``goal``, ``initial_pose``, ``teleop`` and ``cancel``; the operator page speaks this;
- ``/goal_pose`` or ``/move_base_simple/goal``: a geometry_msgs/PoseStamped (a goal);
- ``/initialpose``: a geometry_msgs/PoseWithCovarianceStamped (where the robot is);
- ``/cmd_vel``: a geometry_msgs/Twist (driving by hand).

The ROS-shaped ones are what Foxglove's 3D panel and teleop panel publish. Each carries a
top-level ``"token"`` (one of those the caller accepts) unless the view takes commands
without one. A command is refused whole, with the reason, when it is too large, not JSON, of
a type a viewer may not send, missing a field or out of bounds, or without an accepted token;
it then never reaches the bus.
"""

from __future__ import annotations

import hmac
import json
import math
from collections.abc import Callable, Mapping
from typing import Any

from pydantic import ValidationError

from navd.viz.errors import CommandRefusedError
from navd.viz.settings import VizSettings
from navd.wire import (
    CancelFrame,
    ControlRequest,
    EmergencyStopFrame,
    GoalFrame,
    InitialPoseFrame,
    TeleopFrame,
    WireError,
    decode_control_object,
)

__all__ = [
    "COMMAND_TOPICS",
    "MAX_COMMAND_BYTES",
    "CommandRefusedError",
    "read_command",
    "viewer_request",
]

MAX_COMMAND_BYTES = 16_384
NAVD_TOPIC = "/navd/command"
# What a viewer may ask for on navd's own topic: steering, not configuring.
VIEWER_REQUESTS = (GoalFrame, InitialPoseFrame, TeleopFrame, CancelFrame, EmergencyStopFrame)


def _yaw(orientation: Mapping[str, Any]) -> float:
    """[rad] the yaw of a quaternion {x, y, z, w} (a robot on the ground: roll and pitch
    are ignored)."""
    x, y, z, w = (float(orientation.get(k, 0.0)) for k in ("x", "y", "z", "w"))
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _pose(message: Mapping[str, Any]) -> tuple[float, float, float]:
    """(x, y, yaw) of a pose {position, orientation}."""
    pose = message["pose"]
    position = pose["position"]
    return float(position["x"]), float(position["y"]), _yaw(pose.get("orientation", {}))


def _goal_pose(message: Mapping[str, Any]) -> ControlRequest:
    x, y, yaw = _pose(message)
    return GoalFrame(x=x, y=y, yaw=yaw)


def _initial_pose(message: Mapping[str, Any]) -> ControlRequest:
    """A PoseWithCovarianceStamped: its covariance gives the uncertainty when it has one."""
    x, y, yaw = _pose(message["pose"])
    covariance = message["pose"].get("covariance") or []
    if len(covariance) == 36 and covariance[0] > 0 and covariance[35] > 0:
        std_xy, std_yaw = math.sqrt(covariance[0]), math.sqrt(covariance[35])
        return InitialPoseFrame(x=x, y=y, yaw=yaw, std_xy=std_xy, std_yaw=std_yaw)
    return InitialPoseFrame(x=x, y=y, yaw=yaw)


def _twist(message: Mapping[str, Any]) -> ControlRequest:
    linear = message.get("linear", {})
    angular = message.get("angular", {})
    return TeleopFrame(linear_x=float(linear.get("x", 0.0)), angular_z=float(angular.get("z", 0.0)))


def _navd(message: Mapping[str, Any]) -> ControlRequest:
    frame = decode_control_object(message)
    if not isinstance(frame, VIEWER_REQUESTS):
        allowed = ", ".join(sorted(f.model_fields["type"].default for f in VIEWER_REQUESTS))
        raise CommandRefusedError(f"a viewer may send {allowed}, not {frame.type!r}")
    return frame


COMMAND_TOPICS: dict[str, Callable[[Mapping[str, Any]], ControlRequest]] = {
    NAVD_TOPIC: _navd,
    "/goal_pose": _goal_pose,
    "/move_base_simple/goal": _goal_pose,
    "/initialpose": _initial_pose,
    "/cmd_vel": _twist,
}


def read_command(topic: str, data: bytes, tokens: tuple[str, ...] | None) -> ControlRequest:
    """The control request a viewer published on ``topic``.

    Args:
        topic: the topic of the viewer's channel.
        data: the JSON message.
        tokens: the secrets a command may carry (one of them it must), or None where none is
            needed (``viz.untokened_commands`` on loopback).

    Raises:
        CommandRefusedError: naming what was wrong.
    """
    read = COMMAND_TOPICS.get(topic)
    if read is None:
        raise CommandRefusedError(
            f"{topic!r} is not a command topic; publish on one of {', '.join(COMMAND_TOPICS)}"
        )
    if len(data) > MAX_COMMAND_BYTES:
        raise CommandRefusedError(f"{len(data)} bytes is more than a command may be")
    try:
        message = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise CommandRefusedError(f"not JSON: {err}") from err
    except RecursionError as err:
        raise CommandRefusedError("not a command: nested too deep") from err
    if not isinstance(message, dict):
        raise CommandRefusedError("a command is a JSON object")
    given = message.pop("token", None)
    if tokens is not None and not (
        isinstance(given, str)
        and any(hmac.compare_digest(given.encode(), t.encode()) for t in tokens)
    ):
        raise CommandRefusedError(
            'missing or wrong token: a command carries "token": the run\'s own (the operator '
            "page on this machine has it) or tcp.token; or set viz.untokened_commands on a "
            "loopback view"
        )
    try:
        return read(message)
    except CommandRefusedError:
        raise
    except WireError as err:
        raise CommandRefusedError(str(err)) from err
    except ValidationError as err:
        problem = err.errors()[0]
        where = ".".join(str(p) for p in problem["loc"])
        text = f"{where}: {problem['msg']}" if where else str(problem["msg"])
        raise CommandRefusedError(text) from err
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise CommandRefusedError(f"not a {topic} message: {type(err).__name__}: {err}") from err


def _engages_a_stop(topic: str, data: bytes) -> bool:
    """Whether a viewer's command engages the emergency stop (its token not looked at)."""
    if topic != NAVD_TOPIC or len(data) > MAX_COMMAND_BYTES:
        return False
    try:
        message = json.loads(data)
    except (ValueError, RecursionError):
        return False
    return (
        isinstance(message, dict)
        and message.get("type") == "estop"
        and message.get("engaged", True) is True
    )


def viewer_request(
    topic: str, data: bytes, settings: VizSettings, command_token: str
) -> ControlRequest:
    """A viewer's command as the request it becomes, by the view's rules: commands on
    (``viz.commands``), a token accepted (this run's ``command_token`` or ``tcp.token``; none
    with ``viz.untokened_commands`` on loopback), and driving by hand on for a velocity.

    Raises:
        CommandRefusedError: naming the rule or the field that refused it.
    """
    if _engages_a_stop(topic, data):  # stopping is always allowed: no token, any view
        return EmergencyStopFrame(engaged=True)
    if not settings.commands:
        raise CommandRefusedError("viz.commands is false: this view is read-only")
    tokens = (
        None
        if settings.untokened_commands and not settings.remote
        else (command_token, *((settings.token,) if settings.token else ()))
    )
    frame = read_command(topic, data, tokens)
    if isinstance(frame, TeleopFrame) and not settings.teleop_enabled:
        raise CommandRefusedError("teleop.enabled is false: driving by hand is off")
    return frame
