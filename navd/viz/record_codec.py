"""Bus messages as the JSON of a recording, and back.

Each recorded message is one JSON object of its fields: numbers, strings, lists; arrays as
``{"dtype", "shape", "base64"}`` (exact, and compact for scans and maps); a wire model
(a mission's progress) as its JSON object. A number JSON cannot hold (NaN, infinity) is
spelled ``"NaN"``, ``"Infinity"`` or ``"-Infinity"``: a field that is such a number is left
out and listed in ``not_finite`` (``[{"field", "value"}]``), so each number field holds only
numbers, as its JSON schema says (``record_schema``); inside a list it stands in place
(and recordings made before December 2026 have it in place everywhere).
A message reads back equal to the one written (arrays equal, element by element).

Topics: ``/navd/in/<Type>`` for what the daemon received (replayed), ``/navd/out/<Type>``
for what it decided (compared after a replay), ``/navd/info/<Type>`` for what is neither
(a GPS goal, whose map-frame goal is recorded as received input), ``/navd/config`` for the
config the daemon ran on and ``/navd/session`` for the session's header.
"""

from __future__ import annotations

import base64
import dataclasses
import json
import math
import typing
from collections.abc import Mapping
from enum import Enum
from typing import Any

import numpy as np
from pydantic import BaseModel

from navd.lifecycle.messages import (
    BeaconObservation,
    CancelGoal,
    CompassHeading,
    ConfigChange,
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DeviceResumed,
    DeviceStale,
    DriveCommand,
    DriveMode,
    GeoGoal,
    Goal,
    GoalStatus,
    GpsFix,
    Imu,
    InitialPose,
    LaserScan,
    LocalizationState,
    LoopTicks,
    ManualCommand,
    MapUpdate,
    Message,
    MissionStatus,
    Path,
    PoseEstimate,
    SafetyState,
    SaveMapRequest,
    SetUpDone,
    Vector3,
    WheelOdometry,
    WorkerJob,
)
from navd.viz.errors import RecordCodecError

__all__ = [
    "CONFIG_TOPIC",
    "INFO",
    "INPUTS",
    "NOT_FINITE",
    "OUTPUTS",
    "SESSION_TOPIC",
    "RecordCodecError",
    "decode",
    "encode",
    "kind_of",
    "topic_of",
]

# What the daemon's edges (the TCP server, the chassis) put on the bus: replayed.
INPUTS: tuple[type[Message], ...] = (
    LaserScan,
    Imu,
    GpsFix,
    CompassHeading,
    WheelOdometry,
    BeaconObservation,
    DeviceConnected,
    DeviceLost,
    DeviceStale,
    DeviceResumed,
    Goal,
    CancelGoal,
    InitialPose,
    ManualCommand,
    SaveMapRequest,
    ConfigChange,
)
# What the daemon decided: compared with a replay's.
OUTPUTS: tuple[type[Message], ...] = (
    PoseEstimate,
    LocalizationState,
    Path,
    DriveCommand,
    GoalStatus,
    SafetyState,
    DriveMode,
    MapUpdate,
)
# Kept for people, not replayed (the goals they become are inputs); the worker jobs', the
# periodic loops' and the set-ups' timing, which a replay follows (``WorkerPool.follow``,
# ``LoopTimes.follow``).
INFO: tuple[type[Message], ...] = (GeoGoal, MissionStatus, WorkerJob, LoopTicks, SetUpDone)
CONFIG_TOPIC = "/navd/config"
# The session's header (JSON): its name, the file's index, when it began in the daemon's run
# and what the daemon knew then.
SESSION_TOPIC = "/navd/session"

_BY_TOPIC: dict[str, type[Message]] = {
    **{f"/navd/in/{kind.__name__}": kind for kind in INPUTS},
    **{f"/navd/out/{kind.__name__}": kind for kind in OUTPUTS},
    **{f"/navd/info/{kind.__name__}": kind for kind in INFO},
}
_TOPIC_OF = {kind: topic for topic, kind in _BY_TOPIC.items()}
_NOT_FINITE = {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf}
NOT_FINITE = "not_finite"  # the fields left out for a value JSON cannot hold, and the value


def kind_of(topic: str) -> type[Message] | None:
    """The message type recorded on ``topic``, or None when it holds none."""
    return _BY_TOPIC.get(topic)


def topic_of(kind: type[Message]) -> str | None:
    """The topic ``kind`` is recorded on, or None when it is not recorded."""
    return _TOPIC_OF.get(kind)


def _plain(value: Any) -> Any:
    """A field's value as JSON can hold it."""
    if isinstance(value, np.ndarray):
        data = np.ascontiguousarray(value)
        return {
            "dtype": data.dtype.str,
            "shape": list(data.shape),
            "base64": base64.b64encode(data.tobytes()).decode("ascii"),
        }
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, BaseModel):
        return value.model_dump(mode="json")
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, np.generic):
        return value.item()
    return value


def encode(message: Message) -> bytes:
    """The message's fields as one JSON object (UTF-8)."""
    fields: dict[str, Any] = {}
    not_finite: list[dict[str, str]] = []
    for field in dataclasses.fields(message):
        value = getattr(message, field.name)
        if isinstance(value, float) and not math.isfinite(value):
            not_finite.append({"field": field.name, "value": _plain(value)})
        else:
            fields[field.name] = _plain(value)
    if not_finite:
        fields[NOT_FINITE] = not_finite
    return json.dumps(fields, separators=(",", ":")).encode()


_HINTS: dict[type[Message], dict[str, Any]] = {}


def _hints(kind: type[Message]) -> dict[str, Any]:
    """The field types of ``kind`` (resolved once)."""
    hints = _HINTS.get(kind)
    if hints is None:
        hints = _HINTS[kind] = typing.get_type_hints(kind)
    return hints


def _typed(hint: Any, value: Any) -> Any:
    """``value`` read back as the field's type ``hint`` says."""
    if isinstance(value, dict) and "base64" in value:
        raw = base64.b64decode(value["base64"])
        return np.frombuffer(raw, dtype=np.dtype(value["dtype"])).reshape(value["shape"]).copy()
    options = typing.get_args(hint) if typing.get_origin(hint) in (typing.Union, _UNION) else ()
    if value is None:
        return None
    if hint is DeviceKind:
        return DeviceKind(value)
    if isinstance(hint, type) and issubclass(hint, BaseModel):
        return hint.model_validate(value)
    if (hint is Vector3 or Vector3 in options) and isinstance(value, list):
        return Vector3(*value)
    if isinstance(value, str) and (hint is float or float in options):
        return _NOT_FINITE.get(value, value)
    if isinstance(value, list):
        return tuple(_typed(Any, v) for v in value)
    return value


_UNION = type(int | None)


def decode(topic: str, data: bytes) -> Message:
    """The message recorded on ``topic``.

    Raises:
        RecordCodecError: an unknown topic, or data that is not that message.
    """
    kind = _BY_TOPIC.get(topic)
    if kind is None:
        raise RecordCodecError(f"{topic!r} is not a topic navd records")
    try:
        fields = json.loads(data)
        for entry in fields.pop(NOT_FINITE, ()):
            fields[entry["field"]] = _NOT_FINITE[entry["value"]]
        if kind is MissionStatus and "info" not in fields:
            fields = _flat_mission_status(fields)  # recorded before December 2026
        hints = _hints(kind)
        values = {name: _typed(hints[name], value) for name, value in fields.items()}
        return kind(**values)
    except (ValueError, TypeError, KeyError, RecursionError) as err:
        raise RecordCodecError(f"{topic}: not a {kind.__name__}: {err}") from err


def _flat_mission_status(fields: dict[str, Any]) -> dict[str, Any]:
    """A MissionStatus recorded with its progress's fields beside its stamps, as the message
    held them before its progress was the wire's ``MissionInfo``: nested as it is now (NaN,
    recorded as "NaN", read as unknown)."""
    stamps: dict[str, Any] = {k: fields.pop(k) for k in ("stamp", "received") if k in fields}
    for key in ("distance_m", "eta_s"):
        if fields.get(key) in ("NaN", "Infinity", "-Infinity"):
            fields[key] = None
    return {**stamps, "info": fields}
