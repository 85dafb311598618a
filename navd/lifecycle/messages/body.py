"""What the robot's other sensors measured: range sensors, bumpers and cliff sensors, depth
cameras, the battery."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from navd.lifecycle.errors import MessageError
from navd.lifecycle.messages.base import Message, read_only, require_finite

__all__ = ["BatteryAlarm", "BatteryState", "Contact", "DepthPoints", "RangeReading"]


@dataclass(frozen=True, slots=True, kw_only=True)
class RangeReading(Message):
    """A range sensor's reading: the nearest thing in its cone.

    Attributes:
        device_id: the device; sensor: which of its sensors (its mount's name).
        range_m: [m] how far the nearest thing is; inf: nothing within ``max_range_m``.
        field_of_view_rad: [rad] the cone's full angle.
        min_range_m, max_range_m: [m] what it can measure.
    """

    device_id: str
    sensor: str
    range_m: float
    field_of_view_rad: float
    min_range_m: float
    max_range_m: float

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        for name in ("field_of_view_rad", "min_range_m", "max_range_m"):
            require_finite(name, getattr(self, name))
        if math.isnan(self.range_m) or self.range_m < 0.0:
            raise MessageError(f"range_m must be >= 0 or inf, got {self.range_m}")

    @property
    def clear(self) -> bool:
        """Nothing within reach."""
        return self.range_m > self.max_range_m


@dataclass(frozen=True, slots=True, kw_only=True)
class Contact(Message):
    """A bumper's or a cliff sensor's state.

    Attributes:
        device_id: the device; sensor: which of its sensors (its mount's name).
        kind: "bumper" or "cliff".
        triggered: pressed, or the floor gone.
    """

    device_id: str
    sensor: str
    kind: Literal["bumper", "cliff"]
    triggered: bool


@dataclass(frozen=True, slots=True, kw_only=True)
class DepthPoints(Message):
    """A depth camera's points in its own body axes (x forward, y left, z up).

    Attributes:
        device_id: the device; sensor: which camera (its mount's name).
        points_m: [m] N x 3 (read-only).
    """

    device_id: str
    sensor: str
    points_m: npt.NDArray[np.float64]

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        points = read_only("points_m", self.points_m, np.float64, 2)
        if points.shape[1:] != (3,):
            raise MessageError(f"points_m must be N x 3, got shape {points.shape}")
        object.__setattr__(self, "points_m", points)


@dataclass(frozen=True, slots=True, kw_only=True)
class BatteryState(Message):
    """The battery as its sensor reports it.

    Attributes:
        device_id: the battery's sensor.
        voltage_v: [V]; current_a: [A], negative while discharging (NaN: not known).
        percentage: [0, 1] charge (NaN: not known); charging: None when not known.
    """

    device_id: str
    voltage_v: float
    current_a: float = math.nan
    percentage: float = math.nan
    charging: bool | None = None

    def __post_init__(self) -> None:
        Message.__post_init__(self)
        require_finite("voltage_v", self.voltage_v)
        if not (math.isnan(self.percentage) or 0.0 <= self.percentage <= 1.0):
            raise MessageError(f"percentage must be in [0, 1], got {self.percentage}")


@dataclass(frozen=True, slots=True, kw_only=True)
class BatteryAlarm(Message):
    """The battery's charge crossed a threshold (``battery.low_percent``,
    ``battery.critical_percent``), or recovered above one.

    Attributes:
        level: "ok", "low" or "critical".
        percentage: [0, 1] the charge that set it.
    """

    level: Literal["ok", "low", "critical"]
    percentage: float
