"""The message base: stamps, the checks every message shares, device kinds, 3-vectors."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum, StrEnum
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from navd.lifecycle.errors import MessageError

__all__ = ["DeviceKind", "FloatArray", "Message", "Vector3", "describe"]

FloatArray = npt.NDArray[np.float64]


def require_finite(name: str, value: float) -> None:
    if not math.isfinite(value):
        raise MessageError(f"{name} must be a finite number, got {value!r}")


def read_only(
    name: str, values: npt.ArrayLike, dtype: type[np.generic], ndim: int
) -> npt.NDArray[Any]:
    array = np.array(values, dtype=dtype, copy=True)
    if array.ndim != ndim:
        raise MessageError(f"{name} must be a {ndim}-D array, got shape {array.shape}")
    array.flags.writeable = False
    return array


class Vector3(NamedTuple):
    """A 3-vector in the sensor frame; the unit is given by the field holding it."""

    x: float
    y: float
    z: float


class DeviceKind(StrEnum):
    """What a connected peripheral is."""

    LIDAR = "lidar"
    IMU = "imu"
    GPS = "gps"
    COMPASS = "compass"
    BEACON = "beacon"
    WHEEL_ODOMETRY = "wheel_odometry"
    RANGE = "range"
    CONTACT = "contact"
    POINTS = "points"
    BATTERY = "battery"
    CONTROL = "control"
    CHASSIS = "chassis"
    CLOCK = "clock"


@dataclass(frozen=True, slots=True, kw_only=True)
class Message:
    """Base of every message.

    Attributes:
        stamp: [s] time of measurement on the daemon clock.
        received: [s] time the message reached the daemon, on the same clock.
    """

    stamp: float
    received: float

    def __post_init__(self) -> None:
        # one test on the hot path (a thousand IMU samples a second); the named check after
        if not (math.isfinite(self.stamp) and math.isfinite(self.received)):
            require_finite("stamp", self.stamp)
            require_finite("received", self.received)


def describe(message: Message) -> dict[str, object]:
    """A short, loggable summary of a message: scalars as they are, arrays by shape."""
    summary: dict[str, object] = {"type": type(message).__name__}
    for cls in type(message).__mro__:
        for name in getattr(cls, "__slots__", ()):
            if name in summary:
                continue
            value = getattr(message, name, None)
            if isinstance(value, np.ndarray):
                summary[name] = f"array{value.shape}"
            elif isinstance(value, str | int | float | bool | type(None) | Enum):
                summary[name] = value
            else:
                text = repr(value)
                summary[name] = text if len(text) <= 120 else text[:117] + "..."
    return summary
