"""What the robot's other sensors send: a range sensor's reading, a bumper's or a cliff
sensor's state, a depth camera's points, and the battery's state (sensor_msgs/Range,
PointCloud2's xyz and BatteryState, in ROS's units).

A device with several sensors of one kind (an MCU with four bumpers and two cliff sensors, a
ring of ultrasonic sensors) sends them on one connection: each frame names its ``sensor``,
whose mount (``[mounts.ranges.NAME]``, ``[mounts.contacts.NAME]``, ``[mounts.depth.NAME]``)
places it on the robot; without a name the frame is the device's own.
"""

from __future__ import annotations

import base64
import binascii
import math
from typing import Any, Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from navd.wire.base import SENSOR_NAME_PATTERN, Frame, Stamp
from navd.wire.errors import WireError

__all__ = [
    "MAX_POINTS",
    "BatteryFrame",
    "ContactFrame",
    "PointsFrame",
    "RangeFrame",
]

MAX_POINTS = 100_000  # a depth camera's points in one frame (a 320 x 240 image is 76 800)
SensorName = Field(None, pattern=SENSOR_NAME_PATTERN)


class RangeFrame(Frame):
    """One range sensor's reading (sensor_msgs/Range): an ultrasonic sensor or a
    time-of-flight one measures the nearest thing in a cone.

    ``range`` within [``min_range``, ``max_range``] is something that far away somewhere in
    the cone of full angle ``field_of_view``; ``null``, ``inf`` or beyond ``max_range`` is
    nothing within reach (the cone is clear); below ``min_range`` is too near to tell, taken
    as something at ``min_range``.
    """

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True, allow_inf_nan=True)

    type: Literal["range"] = "range"
    stamp: Stamp
    sensor: str | None = SensorName
    range: float | None = Field(ge=0)
    field_of_view: float = Field(gt=0, le=math.pi, allow_inf_nan=False)
    min_range: float = Field(0.0, ge=0, allow_inf_nan=False)
    max_range: float = Field(gt=0, le=100, allow_inf_nan=False)
    radiation_type: Literal["ultrasound", "infrared"] = "ultrasound"

    @model_validator(mode="after")
    def _consistent(self) -> RangeFrame:
        if self.max_range <= self.min_range:
            raise ValueError(
                f"max_range: must exceed min_range ({self.min_range}), got {self.max_range}"
            )
        if self.range is not None and math.isnan(self.range):
            raise ValueError("range: NaN is not a reading; send null for nothing within reach")
        return self


class ContactFrame(Frame):
    """A bumper's or a cliff sensor's state: ``triggered`` while the bumper is pressed or the
    floor has fallen away under the cliff sensor. Sent when it changes and at least every
    ``tcp.contact_timeout_s`` between (a silent contact sensor holds the robot)."""

    type: Literal["contact"] = "contact"
    stamp: Stamp
    sensor: str | None = SensorName
    kind: Literal["bumper", "cliff"]
    triggered: bool


class PointsFrame(Frame):
    """A depth camera's points in its own frame (sensor_msgs/PointCloud2's x, y, z): base64
    of little-endian float32 triples in ``points_f32``, the camera's optical frame (z
    forward, x right, y down) unless ``frame`` says ``body`` (x forward, y left, z up). Its
    mount places the camera on the robot; the points within the robot's height band become
    obstacles (a table top a 2D lidar passes under)."""

    type: Literal["points"] = "points"
    stamp: Stamp
    sensor: str | None = SensorName
    frame: Literal["optical", "body"] = "optical"
    points_f32: str = Field(max_length=(MAX_POINTS * 12 * 4) // 3 + 4)

    def points_array(self) -> np.ndarray[Any, np.dtype[np.float64]]:
        """[m] N x 3 points in the camera's body axes (x forward, y left, z up); NaN and
        inf points dropped.

        Raises:
            WireError: ``points_f32`` is not base64 of whole xyz float32 triples.
        """
        try:
            raw = base64.b64decode(self.points_f32, validate=True)
        except binascii.Error as err:
            raise WireError("points_f32", f"not valid base64: {err}") from err
        if len(raw) % 12:
            raise WireError("points_f32", f"{len(raw)} bytes is not a whole number of xyz")
        xyz = np.frombuffer(raw, dtype="<f4").reshape(-1, 3).astype(np.float64)
        xyz = xyz[np.isfinite(xyz).all(axis=1)]
        if self.frame == "optical":  # z forward, x right, y down -> x forward, y left, z up
            xyz = np.column_stack([xyz[:, 2], -xyz[:, 0], -xyz[:, 1]])
        return xyz


class BatteryFrame(Frame):
    """The battery's state (sensor_msgs/BatteryState): ``voltage`` [V], ``current`` [A,
    negative while discharging, as ROS has it], ``percentage`` of charge in [0, 1] (as ROS
    has it; null when not known), and whether it ``charging``."""

    type: Literal["battery"] = "battery"
    stamp: Stamp
    voltage: float = Field(ge=0, le=1000, allow_inf_nan=False)
    current: float | None = Field(None, ge=-1000, le=1000, allow_inf_nan=False)
    percentage: float | None = Field(None, ge=0, le=1, allow_inf_nan=False)
    charging: bool | None = None
