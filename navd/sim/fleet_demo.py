"""``navd demo --fleet N``: N simulated robots, each its own navd, on a local mosquitto, with
four UWB-like beacons; ``navd fleet``'s group goal drives them in a triangle. Up to three
robots cross the built-in office, from the lower-left room through its 1 m door and the
corridor's 1.5 m corner to the lower-right area, in a column where the triangle does not fit;
four to six, too many for a triangle 1.5 m apart in the office's rooms, cross a 16 m x 12 m
hall. Writes ``fleet.png`` (each robot's way, the group centre's route) and
``fleet_summary.json``."""

from __future__ import annotations

import asyncio
import dataclasses
import json
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from navd.fleetctl import GroupGoal, GroupMap, drive_group, fleet_view
from navd.geometry import Pose2
from navd.sim.broker import LocalBroker
from navd.sim.errors import SimError
from navd.sim.fleet import fleet_sessions
from navd.sim.picture import fleet_picture
from navd.sim.sim_session import Session
from navd.sim.world import World, from_shapes, office

__all__ = [
    "MAX_ROBOTS",
    "OFFICE_ANCHORS",
    "OFFICE_ROBOTS",
    "hall",
    "office_with_beacons",
    "on_beacons",
    "run_fleet_demo",
]

MAX_ROBOTS = 6  # each is a navd process and a simulator: more than a laptop wants
OFFICE_ROBOTS = 3  # more do not fit a triangle 1.5 m apart in the office's rooms
ANCHORS = {"u1": (-0.5, -0.5), "u2": (14.5, -0.5), "u3": (14.5, 10.5), "u4": (-0.5, 10.5)}
OFFICE_ANCHORS = {"u1": (-0.5, -0.5), "u2": (10.5, -0.5), "u3": (10.5, 6.5), "u4": (-0.5, 6.5)}
HALL_GOAL = (11.0, 5.0)
OFFICE_GOAL = (9.4, 1.5)  # the lower-right area, facing east
# where the robots start in the office's lower-left room (clear of its desk)
OFFICE_STARTS = ((0.0, 0.0), (0.0, 1.6), (1.2, 0.0))
SENSORS = {"beacon_rate_hz": 20.0, "beacon_range_noise_m": 0.05}


def on_beacons(anchors: dict[str, tuple[float, float]]) -> dict[str, Any]:
    """Config sections for robots localized by ``anchors`` alone (the lidar only sees
    obstacles and the other robots)."""
    return {
        "slam": {"enabled": False},
        "beacons": {"known": {b: {"x_m": x, "y_m": y} for b, (x, y) in anchors.items()}},
    }


def office_with_beacons() -> World:
    """The built-in office with a UWB-like beacon in each corner."""
    return dataclasses.replace(
        office(), beacons=tuple((b, x, y) for b, (x, y) in OFFICE_ANCHORS.items())
    )


def hall() -> World:
    """A 16 m x 12 m hall with a UWB-like beacon in each corner and a pillar."""
    walls = [[-1.0, -1.0, 15.0, -1.0], [15.0, -1.0, 15.0, 11.0], [15.0, 11.0, -1.0, 11.0],
             [-1.0, 11.0, -1.0, -1.0]]  # fmt: skip
    spec: dict[str, Any] = {
        "walls": walls,
        "circles": [[6.5, 9.0, 0.3]],
        "beacons": [{"id": b, "x": x, "y": y} for b, (x, y) in ANCHORS.items()],
    }
    return from_shapes(spec, "hall")


async def _online(url: str, fleet: list[Session], count: int, limit_s: float) -> None:
    loop = asyncio.get_running_loop()
    deadline = loop.time() + limit_s
    while loop.time() < deadline:
        for s in fleet:
            s.check()
        view = await fleet_view(url, listen_s=0.5)
        if (
            sum(v.connection == "ONLINE" and v.position is not None for v in view.vehicles.values())
            >= count
        ):
            return
        await asyncio.sleep(0.5)
    raise SimError(f"not all {count} robots came online with a position within {limit_s:g} s")


@dataclass(frozen=True)
class _Scene:
    """Where the demo's robots drive: the world, their starts [m], the beacons they localize
    on, the group's goal [m] and heading [rad], the map the group plans on (None: open
    ground)."""

    world: World
    starts: list[tuple[float, float]]
    anchors: dict[str, tuple[float, float]]
    goal_xy_m: tuple[float, float]
    heading_rad: float | None
    walls: GroupMap | None


def _scene(count: int) -> _Scene:
    """The office crossing for up to OFFICE_ROBOTS robots, the hall for more."""
    if count <= OFFICE_ROBOTS:
        world = office_with_beacons()
        origin = (world.origin_x_m, world.origin_y_m)
        walls = GroupMap.of_grid(world.grid, origin, world.resolution_m)
        return _Scene(world, list(OFFICE_STARTS[:count]), OFFICE_ANCHORS, OFFICE_GOAL, 0.0, walls)
    starts = [(1.5, 1.5 + k * 7.0 / max(count - 1, 1)) for k in range(count)]
    return _Scene(hall(), starts, ANCHORS, HALL_GOAL, None, None)


async def _drive(scene: _Scene, folder: Path, url: str, limit_s: float) -> dict[str, Any]:
    robots = [(f"robot-{k + 1}", Pose2(x, y, 0.0)) for k, (x, y) in enumerate(scene.starts)]
    overrides = on_beacons(scene.anchors)
    async with fleet_sessions(
        scene.world, folder, robots, url, overrides=overrides, sim_settings=SENSORS
    ) as fleet:
        await _online(url, fleet, len(robots), 60.0)
        goal = GroupGoal(
            *scene.goal_xy_m, heading_rad=scene.heading_rad, formation="triangle", spacing_m=1.5
        )
        summary = await drive_group(url, goal, timeout_s=limit_s, group_map=scene.walls)
        truths = [np.array([(x, y) for _, x, y, _ in s.sim.truth]) for s in fleet]
        collisions = [s.sim.body.collisions for s in fleet]
    ends = np.array([t[-1] for t in truths])
    summary.update(
        world=scene.world.name,
        collisions=sum(collisions),
        centre_error_m=round(math.dist(ends.mean(axis=0), scene.goal_xy_m), 3),
        driven_m=[round(float(np.hypot(*np.diff(t, axis=0).T).sum()), 1) for t in truths],
        trajectories=[t.tolist() for t in truths],
    )
    return summary


def run_fleet_demo(count: int, out: Path, *, limit_s: float = 300.0) -> dict[str, Any]:
    """Run the demo (see the module docstring); the summary, as written.

    Raises:
        SimError: mosquitto is missing, a robot would not start, or ``count`` is out of range.
    """
    if not 1 <= count <= MAX_ROBOTS:
        raise SimError(f"--fleet takes 1 to {MAX_ROBOTS} robots, got {count}")
    out.mkdir(parents=True, exist_ok=True)
    scene = _scene(count)
    with tempfile.TemporaryDirectory(prefix="navd-fleet-") as folder:
        broker = LocalBroker(Path(folder))
        broker.start()
        try:
            summary = asyncio.run(_drive(scene, Path(folder), broker.url, limit_s))
        finally:
            broker.stop()
    trajectories = [np.array(t) for t in summary.pop("trajectories")]
    route = np.array(summary["route_m"])
    fleet_picture(scene.world, trajectories, scene.goal_xy_m, out / "fleet.png", route_m=route)
    (out / "fleet_summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return summary
