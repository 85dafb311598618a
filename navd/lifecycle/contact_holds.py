"""Bumpers and cliff sensors in the safety gate: while one is triggered, the robot may only
back away from it.

A triggered sensor stops the robot at once. Then a command passes only if it moves the
sensor's point of the robot away from what it felt: the point's velocity, (v - ω y, ω x) for
a point (x, y) of a robot driven at (v, ω), must not point the way the sensor faces (a
front bumper: no forward motion; turning on the spot, which moves the front point sideways,
is allowed). A sensor without a mount allows no motion at all until it is released. A
released sensor holds nothing; what it felt stays in the planner's proximity layer.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from navd.config import NavdConfig
from navd.geometry import ContactMount, SensorMounts
from navd.lifecycle.messages import Contact

__all__ = ["ContactHolds", "contact_mounts"]

# A point moving towards its sensor's facing slower than this [m/s] is not pressing on.
PRESSING_MPS = 1e-3


def contact_mounts(config: NavdConfig) -> Mapping[str, ContactMount]:
    """The bumpers' and cliff sensors' mounts, by sensor name."""
    return SensorMounts.of(config.mounts, config.lidar).body.contacts


class ContactHolds:
    """The triggered bumpers and cliff sensors, and what motion they allow."""

    def __init__(self) -> None:
        self._active: dict[str, Contact] = {}  # by sensor, while triggered

    def take(self, contact: Contact) -> bool:
        """Take a sensor's state; True when it just became triggered (stop now)."""
        if not contact.triggered:
            self._active.pop(contact.sensor, None)
            return False
        fresh = contact.sensor not in self._active
        self._active[contact.sensor] = contact
        return fresh

    def release(self, sensor: str) -> bool:
        """Forget ``sensor`` (its device left); True if it was triggered."""
        return self._active.pop(sensor, None) is not None

    @property
    def active(self) -> bool:
        return bool(self._active)

    def reasons(self) -> list[str]:
        """Each triggered sensor, as the status shows it."""
        return [
            f"{c.kind} {c.sensor!r} " + ("pressed" if c.kind == "bumper" else "sees no floor")
            for c in self._active.values()
        ]

    def allows(
        self, linear_mps: float, angular_radps: float, mounts: Mapping[str, ContactMount]
    ) -> bool:
        """Whether (v, ω) backs away from every triggered sensor."""
        for sensor in self._active:
            mount = mounts.get(sensor)
            if mount is None:
                if linear_mps or angular_radps:
                    return False
                continue
            ux = linear_mps - angular_radps * mount.y_m
            uy = angular_radps * mount.x_m
            pressing = ux * math.cos(mount.facing_rad) + uy * math.sin(mount.facing_rad)
            if pressing > PRESSING_MPS:
                return False
        return True
