"""Where a mission's driving steps send the robot: a beacon step's waypoints, a gate's two
sides, and an approach's staging and stopping poses.

A beacon step visits its beacons nearest first, from where the robot is; each goal stops
short of its beacon along the way the robot comes, facing it. A gate is crossed square to
the line between its two beacons, from the robot's side: a waypoint before the line, then
one beyond it. An approach drives first to a staging pose ``STAGING_M`` short of where it
stops, then the slow part; both lie along its yaw, or (no yaw given) along the line from
where the robot began the step.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from navd.geometry import Pose2, wrap_angle
from navd.lifecycle.messages import MissionStep
from navd.missions.errors import UnknownBeaconError

__all__ = [
    "GATE_SIDE_M",
    "STAGING_M",
    "Waypoint",
    "approach_pose",
    "beacon_waypoints",
    "waypoint_pose",
]

STAGING_M = 1.0  # [m] an approach first drives to this much before its slow part
GATE_SIDE_M = 1.0  # [m] a gate is passed from this far before its line to this far beyond


@dataclass(frozen=True, slots=True)
class Waypoint:
    """Where a beacon step drives next: a pose, or (``short_m`` set) a point to stop short
    of, facing it, along the way the robot comes.

    Attributes:
        x_m, y_m: [m] the point in the map frame.
        yaw_rad: [rad] the heading to arrive with (None: any).
        short_m: [m] stop this far short of the point (None: drive onto it).
    """

    x_m: float
    y_m: float
    yaw_rad: float | None = None
    short_m: float | None = None


def beacon_waypoints(
    step: MissionStep, places: Mapping[str, tuple[float, float]], pose: Pose2 | None
) -> list[Waypoint]:
    """The waypoints of a beacon, gate or visit_beacons step, from the beacons' ``places``
    [m] and the robot's ``pose`` (None: not known; the first listed beacon leads).

    Raises:
        UnknownBeaconError: a beacon the step names has no place, or none has one yet.
    """
    wanted = step.beacons or tuple(sorted(places))
    if not wanted:
        raise UnknownBeaconError("no beacon has a place yet: list them under [beacons.known]")
    missing = [b for b in wanted if b not in places]
    if missing:
        known = ", ".join(sorted(places)) or "none"
        raise UnknownBeaconError(f"beacon {', '.join(missing)} has no place (known: {known})")
    if step.kind == "gate":
        return _gate_sides(places[wanted[0]], places[wanted[1]], pose)
    left = list(dict.fromkeys(wanted))
    here = (pose.x, pose.y) if pose is not None else places[left[0]]
    order: list[Waypoint] = []
    while left:
        nearest = min(left, key=lambda b: math.dist(here, places[b]))
        left.remove(nearest)
        here = places[nearest]
        order.append(Waypoint(*here, short_m=step.stop_distance_m))
    return order


def _gate_sides(
    a: tuple[float, float], b: tuple[float, float], pose: Pose2 | None
) -> list[Waypoint]:
    """Before and beyond the middle of the line a -> b, square to it, the robot's side
    first."""
    (ax, ay), (bx, by) = a, b
    mx, my = (ax + bx) / 2.0, (ay + by) / 2.0
    across = math.atan2(bx - ax, -(by - ay))
    if pose is not None and math.cos(across) * (mx - pose.x) + math.sin(across) * (my - pose.y) < 0:
        across = wrap_angle(across + math.pi)
    c, s = math.cos(across), math.sin(across)
    return [
        Waypoint(mx - GATE_SIDE_M * c, my - GATE_SIDE_M * s, across),
        Waypoint(mx + GATE_SIDE_M * c, my + GATE_SIDE_M * s, across),
    ]


def waypoint_pose(point: Waypoint, pose: Pose2 | None) -> tuple[float, float, float | None]:
    """[m, m, rad] the goal for ``point``: short of it along the way from ``pose``, facing
    it (where the robot is already that near: where it is, facing it), or the point itself."""
    x, y, yaw = point.x_m, point.y_m, point.yaw_rad
    if point.short_m is None or pose is None:
        return x, y, yaw
    heading = math.atan2(y - pose.y, x - pose.x)
    if math.hypot(x - pose.x, y - pose.y) > point.short_m:
        x -= point.short_m * math.cos(heading)
        y -= point.short_m * math.sin(heading)
    else:
        x, y = pose.x, pose.y
    return x, y, wrap_angle(heading)


def approach_pose(
    step: MissionStep, start: Pose2 | None, *, final: bool
) -> tuple[float, float, float]:
    """[m, m, rad] where an approach stops (``final``) or stages: along its yaw, or along the
    line from ``start`` (where the robot began the step; None: from the west)."""
    if step.yaw_rad is not None:
        heading = step.yaw_rad
    else:
        origin = start or Pose2(step.x_m - 1.0, step.y_m, 0.0)
        heading = math.atan2(step.y_m - origin.y, step.x_m - origin.x)
    back = step.stop_distance_m + (0.0 if final else STAGING_M)
    x = step.x_m - back * math.cos(heading)
    y = step.y_m - back * math.sin(heading)
    return x, y, wrap_angle(heading)
