"""One line of JSON to a typed frame, and a typed frame to one line.

Decoding validates with pydantic straight from the bytes; a line that fails becomes a
``WireError`` naming the field (a dotted path into the frame) and the reason. Each role has
its own decoder: a sensor may send only its own data frame (and ``ping``), a control client
only requests, the clock client only clock steps.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Annotated, Any, TypeVar, Union, get_args

from pydantic import Field, TypeAdapter, ValidationError

from navd.wire.base import Frame, Hello, PingFrame
from navd.wire.control_frames import ClockRequest, ControlRequest
from navd.wire.errors import WireError
from navd.wire.replies import Reply, ReplyPart
from navd.wire.ros_frames import ROS_SENSOR_FRAMES
from navd.wire.sensor_frames import ALSO_SENT, SENSOR_FRAMES, SensorFrame

__all__ = [
    "TAGS",
    "decode_clock",
    "decode_control",
    "decode_control_object",
    "decode_hello",
    "decode_reply",
    "decode_sensor",
    "encode",
    "frame_text",
]

T = TypeVar("T")


def _tagged(union: Any) -> Any:
    """A union of frames told apart by their ``type``."""
    return Annotated[union, Field(discriminator="type")]


_HELLO: TypeAdapter[Hello] = TypeAdapter(Hello)
_CONTROL: TypeAdapter[ControlRequest] = TypeAdapter(_tagged(ControlRequest))
_CLOCK: TypeAdapter[ClockRequest] = TypeAdapter(_tagged(ClockRequest))
_SENSOR: dict[str, TypeAdapter[SensorFrame | PingFrame]] = {
    role: TypeAdapter(_tagged(Union[(frame, *ALSO_SENT.get(role, ()), PingFrame)]))
    for role, frame in SENSOR_FRAMES.items()
}
_ROS_SENSOR: dict[str, TypeAdapter[SensorFrame | PingFrame]] = {
    role: TypeAdapter(_tagged(frame | PingFrame)) for role, frame in ROS_SENSOR_FRAMES.items()
}
_REPLY: TypeAdapter[Reply] = TypeAdapter(_tagged(Reply))


def _tags(*unions: Any) -> frozenset[str]:
    """Every frame tag in the given unions and models, read off their ``type`` fields."""
    tags: set[str] = set()
    for union in unions:
        for model in get_args(union) or (union,):
            tags.update(get_args(model.model_fields["type"].annotation))
    return frozenset(tags)


# Every tag a client may send: pydantic puts the union branch first in an error's path.
TAGS = _tags(Hello, ControlRequest, ClockRequest, *SENSOR_FRAMES.values())


def decode_hello(line: bytes) -> Hello:
    """Decode the first line of a connection.

    Raises:
        WireError: naming the bad field.
    """
    try:
        return _HELLO.validate_json(line, context={"wire": True})
    except ValidationError as err:
        raise _wire_error(err, "hello") from err


def decode_sensor(role: str, line: bytes) -> SensorFrame | PingFrame:
    """Decode a line from a sensor of ``role`` ("lidar", "imu", ...): its data frame or a
    ping. A line with a ROS ``header`` or ``{x, y, z}`` vectors is read as the ROS message
    (``ROS_SENSOR_FRAMES``); others skip that reading's cost.

    Raises:
        WireError: naming the bad field.
    """
    # what only a ROS message dumped as JSON carries: a header, or an {x, y, z} vector
    ros = (b'"header"' in line or b'"x"' in line) and role in _ROS_SENSOR
    if ros and b'"op"' in line:
        return _decode_rosbridge(role, line)
    return _decode((_ROS_SENSOR if ros else _SENSOR)[role], line, role)


def _decode_rosbridge(role: str, line: bytes) -> SensorFrame:
    """A rosbridge ``publish`` operation: ``{"op": "publish", "topic": .., "msg": {..}}``,
    its message read as the ROS message of the connection's role (the tag is implied).
    Python's JSON reader is used: rosbridge writes NaN and Infinity as bare words."""
    try:
        envelope = json.loads(line)
    except (ValueError, RecursionError) as err:  # (arrays nested thousands deep)
        raise WireError("", f"not valid JSON: {err}") from err
    if not isinstance(envelope, dict) or envelope.get("op") != "publish":
        raise WireError("op", "a rosbridge line must be a publish operation (op: publish)")
    msg = envelope.get("msg")
    if not isinstance(msg, dict):
        raise WireError("msg", "a rosbridge publish carries its message as an object in msg")
    model = ROS_SENSOR_FRAMES[role]
    tag = get_args(model.model_fields["type"].annotation)[0]
    try:
        return model.model_validate({**msg, "type": tag})
    except ValidationError as err:
        raise _wire_error(err, role) from err


def decode_control(line: bytes) -> ControlRequest:
    """Decode a line from a control client.

    Raises:
        WireError: naming the bad field.
    """
    return _decode(_CONTROL, line, "control")


def decode_control_object(message: Mapping[str, Any]) -> ControlRequest:
    """A control request already parsed from JSON (a viewer's command: an object, not a
    line), read exactly as the same object sent as a line would be.

    Raises:
        WireError: naming the field that is wrong.
    """
    return decode_control(json.dumps(message).encode())


def decode_clock(line: bytes) -> ClockRequest:
    """Decode a line from the clock client.

    Raises:
        WireError: naming the bad field.
    """
    return _decode(_CLOCK, line, "clock")


def decode_reply(line: bytes) -> Reply:
    """Decode a line from navd (the client's side).

    Raises:
        WireError: the line is not a reply this client knows.
    """
    return _decode(_REPLY, line, "reply")


def encode(frame: Frame | ReplyPart) -> bytes:
    """One frame, a request or a reply, as a JSON line.

    Unset optional fields of a request, and of an ack, are left out; NaN and infinity in a
    reply become null.
    """
    return frame.model_dump_json(exclude_none=frame.OMIT_NONE).encode() + b"\n"


def frame_text(frame: Frame | ReplyPart) -> str:
    """One frame as navd (or a client) sends it, without the line's end: what a command
    line's ``--json`` prints."""
    return encode(frame).decode().rstrip("\n")


def _decode(adapter: TypeAdapter[T], line: bytes, role: str) -> T:
    try:
        return adapter.validate_json(line)
    except ValidationError as err:
        raise _wire_error(err, role) from err


def _wire_error(err: ValidationError, role: str) -> WireError:
    first = err.errors(include_url=False)[0]
    kind = first["type"]
    if kind == "json_invalid":
        return WireError("", f"not valid JSON: {first['msg'].removeprefix('Invalid JSON: ')}")
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return WireError("", "a frame must be a JSON object")
    if kind == "union_tag_not_found":
        return WireError("type", "missing; every frame has a 'type'")
    if kind == "union_tag_invalid":
        expected = first.get("ctx", {}).get("expected_tags", "")
        got = first.get("input", {})
        tag = got.get("type") if isinstance(got, dict) else None
        return WireError(
            "type", f"{tag!r} is not a frame a {role} client sends; expected {expected}"
        )
    # drop the union branch name pydantic puts first ("scan.ranges.3" -> "ranges.3")
    parts = [str(p) for p in first["loc"]]
    if parts and parts[0] in TAGS:
        parts = parts[1:]
    field = ".".join(parts)
    message = str(first["msg"]).removeprefix("Value error, ")
    if kind == "extra_forbidden":
        message = "unknown field"
    if kind == "value_error" and not field:
        # cross-field rules name their field as "field: reason"
        named, sep, rest = message.partition(": ")
        if sep and named.isidentifier():
            field, message = named, rest
    return WireError(field, message)
