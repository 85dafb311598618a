"""The other vehicles as this one hears them on the broker: where each is on our map (its
``visualization``, or its ``state``'s position) and how big (its ``factsheet``), so the
planner can give way to them. One not heard of for ``STALE_S`` is forgotten."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

__all__ = ["MAX_RADIUS_M", "STALE_S", "OtherVehicle", "OtherVehicles"]

MAX_RADIUS_M = 10.0  # [m] another vehicle's size is believed up to this
STALE_S = 2.0  # [s] another vehicle not heard of for this long is forgotten


@dataclass(frozen=True, slots=True)
class OtherVehicle:
    """Another vehicle as last heard: [m, m, rad, m/s] and when (monotonic [s])."""

    x_m: float
    y_m: float
    yaw_rad: float
    speed_mps: float
    heard_s: float


class OtherVehicles:
    """The others, by ``"manufacturer/serial"``."""

    def __init__(self) -> None:
        self.positions: dict[str, OtherVehicle] = {}
        self.radii_m: dict[str, float] = {}  # [m] from their factsheets
        self._told = False  # ``nearby`` has given them as they are now

    def hear(self, name: str, topic: str, raw: bytes, map_id: str, heard_s: float) -> None:
        """``name``'s ``topic`` (``"factsheet"`` or a position message) heard at
        ``heard_s`` [s, monotonic]; a position on another map forgets it.

        Raises:
            ValueError, KeyError, TypeError, AttributeError, RecursionError: the message is
                not one (what is missing or wrong is in the error).
        """
        body = json.loads(raw)
        if topic == "factsheet":
            size = body["physicalParameters"]
            radius = 0.5 * math.hypot(float(size["length"]), float(size["width"]))
            if not 0.0 < radius <= MAX_RADIUS_M:  # also NaN and infinity
                raise ValueError(f"a size of {radius} m")
            self.radii_m[name] = radius
            return
        where = body["agvPosition"]
        if where.get("mapId") != map_id:
            if self.positions.pop(name, None) is not None:
                self._told = False
            return
        speed = float(body.get("velocity", {}).get("vx", 0.0))
        other = OtherVehicle(
            float(where["x"]), float(where["y"]), float(where["theta"]), speed, heard_s
        )
        if all(math.isfinite(v) for v in (other.x_m, other.y_m, other.yaw_rad, other.speed_mps)):
            self.positions[name] = other
            self._told = False

    def nearby(
        self, now_s: float, own_radius_m: float
    ) -> tuple[tuple[str, float, float, float, float, float], ...] | None:
        """The others not stale at ``now_s`` [s, monotonic] as (name, x, y, yaw, speed,
        radius; one without a factsheet has ``own_radius_m``), or None when that is what
        was last given."""
        stale = [n for n, o in self.positions.items() if now_s - o.heard_s > STALE_S]
        for name in stale:
            del self.positions[name]
        if self._told and not stale:
            return None
        self._told = True
        return tuple(
            (name, o.x_m, o.y_m, o.yaw_rad, o.speed_mps, self.radii_m.get(name, own_radius_m))
            for name, o in self.positions.items()
        )
