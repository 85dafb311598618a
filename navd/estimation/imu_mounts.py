"""Each IMU's samples turned into base_link by its mount (``mounts.imus``): a rotation looked
up once per device, applied with plain floats (cheaper than numpy at 1 kHz)."""

from __future__ import annotations

import dataclasses

from navd.geometry import SensorMounts
from navd.lifecycle.messages import Imu, Vector3

__all__ = ["ImuMounts"]

_Rows = tuple[tuple[float, ...], ...]  # a 3 x 3 rotation, row by row
_UNKNOWN: _Rows = ()  # an IMU whose mount is not looked up yet


def _rotate(rows: _Rows, v: Vector3) -> Vector3:
    """``rows`` times the vector ``v`` (plain floats: cheaper than numpy at 1 kHz)."""
    x, y, z = v
    a, b, c = rows
    return Vector3(
        a[0] * x + a[1] * y + a[2] * z,
        b[0] * x + b[1] * y + b[2] * z,
        c[0] * x + c[1] * y + c[2] * z,
    )


class ImuMounts:
    """The IMUs' rotations to base_link, found on each device's first sample.

    Args:
        mounts: the sensors' mounts.
    """

    def __init__(self, mounts: SensorMounts) -> None:
        self._mounts = mounts
        self._rows: dict[str, _Rows | None] = {}  # None: aligned with base_link

    def to_base_link(self, imu: Imu) -> Imu:
        """``imu`` with its vectors in base_link (as it is when its mount is aligned)."""
        rows = self._rows.get(imu.device_id, _UNKNOWN)
        if rows is _UNKNOWN:
            rotation = self._mounts.imu_rotation(imu.device_id)
            rows = None if rotation is None else tuple(tuple(map(float, r)) for r in rotation)
            self._rows[imu.device_id] = rows
        if rows is None:
            return imu
        return dataclasses.replace(
            imu,
            gyro_radps=_rotate(rows, imu.gyro_radps),
            accel_mps2=_rotate(rows, imu.accel_mps2),
            mag_ut=None if imu.mag_ut is None else _rotate(rows, imu.mag_ut),
        )
