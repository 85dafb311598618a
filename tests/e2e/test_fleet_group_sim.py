"""A fleet on a real mosquitto: three simulated robots, each its own navd process, in one
world (each lidar sees the others), localized by four UWB-like beacons; ``navd fleet``'s
group goal takes them in a triangle across the office, all starting together, in a column
through its doors, and two robots sent through one corridor in opposite directions pass
each other. Real time: the
daemons keep their own clocks."""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.fleetctl import GroupGoal, GroupMap, drive_group, fleet_view
from navd.geometry import Pose2
from navd.sim import (
    OFFICE_ANCHORS,
    Session,
    fleet_sessions,
    from_shapes,
    office_with_beacons,
    on_beacons,
)
from tests.fleet.broker import Broker

pytest.importorskip("aiomqtt", reason="aiomqtt missing")
pytestmark = pytest.mark.e2e

ANCHORS = {"u1": (-0.5, -0.5), "u2": (14.5, -0.5), "u3": (14.5, 10.5), "u4": (-0.5, 10.5)}
HALL: dict[str, Any] = {
    "resolution_m": 0.05,
    "walls": [[-1.0, -1.0, 15.0, -1.0], [15.0, -1.0, 15.0, 11.0], [15.0, 11.0, -1.0, 11.0],
              [-1.0, 11.0, -1.0, -1.0]],
    "beacons": [{"id": b, "x": x, "y": y} for b, (x, y) in ANCHORS.items()],
}  # fmt: skip
ON_BEACONS = {
    "slam": {"enabled": False},  # the lidar only sees obstacles (and the other robots)
    "beacons": {"known": {b: {"x_m": x, "y_m": y} for b, (x, y) in ANCHORS.items()}},
}
SENSORS = {"beacon_rate_hz": 20.0, "beacon_range_noise_m": 0.05}


async def _all_online(broker: Broker, fleet: list[Session], count: int) -> None:
    for _ in range(60):
        for s in fleet:
            s.check()
        view = await fleet_view(broker.url, listen_s=0.5)
        ready = [v for v in view.vehicles.values() if v.connection == "ONLINE" and v.position]
        if len(ready) == count:
            return
        await asyncio.sleep(0.5)
    raise AssertionError(f"not all {count} vehicles online with a position: {view.vehicles}")


def _why(summary: dict[str, Any], tmp_path: Path) -> str:
    """The summary and each robot's last few goal and planning events, for a failure."""
    lines = [json.dumps(summary)]
    for log in sorted(tmp_path.glob("*/navd.log")):
        events = [
            line.strip()[:300]
            for line in log.read_text(errors="replace").splitlines()
            if any(f'"{e}"' in line for e in ("goal_done", "plan_failed", "goal_canceled"))
        ]
        lines += [f"{log.parent.name}:", *events[-6:]]
    return "\n".join(lines)


async def test_three_robots_take_a_triangle_across_the_office_through_its_doors(
    tmp_path: Path,
) -> None:
    # the built-in office: from the lower-left room through its 1 m door, the 1.5 m gap at the
    # corridor's corner and round a cabinet to the lower-right area; UWB-like beacons in the
    # corners (the office has none of its own)
    world = office_with_beacons()
    goal = GroupGoal(9.4, 1.5, heading_rad=0.0, formation="triangle", spacing_m=1.5)
    walls = GroupMap.of_grid(world.grid, (world.origin_x_m, world.origin_y_m), world.resolution_m)
    broker = Broker(tmp_path)
    broker.start()
    robots = [
        ("r1", Pose2(0.0, 0.0, 0.0)),
        ("r2", Pose2(1.5, 0.1, 0.0)),
        ("r3", Pose2(0.2, 1.6, 0.0)),
    ]
    try:
        async with fleet_sessions(
            world, tmp_path, robots, broker.url,
            overrides=on_beacons(OFFICE_ANCHORS), sim_settings=SENSORS,
        ) as fleet:  # fmt: skip
            await _all_online(broker, fleet, 3)
            summary = await drive_group(broker.url, goal, timeout_s=420.0, group_map=walls)
            truth = np.array([(s.sim.body.x_m, s.sim.body.y_m) for s in fleet])
            collisions = [s.sim.body.collisions for s in fleet]
            ways = [np.array([(x, y) for _, x, y, _ in s.sim.truth]) for s in fleet]
    finally:
        broker.stop()
    assert summary["reached"] is True, _why(summary, tmp_path)
    # it set off in a column (the triangle does not fit through the room's door) and spread
    # out into the triangle at the goal
    assert summary["shapes"].startswith("column") and summary["shapes"].endswith("triangle x1")
    assert summary["max_shape_error_m"] <= 0.3, _why(summary, tmp_path)
    assert collisions == [0, 0, 0]
    assert math.dist(truth.mean(axis=0), (9.4, 1.5)) < 0.5
    gaps = sorted(math.dist(a, b) for i, a in enumerate(truth) for b in truth[i + 1 :])
    assert gaps == pytest.approx([1.5, 1.5, 1.5], abs=0.3)  # a triangle of 1.5 m sides
    # every robot left the lower-left room (its wall y = 2.5 up to x = 5) through its door
    # (x 3..4)
    for way in ways:
        crossing = way[np.flatnonzero(np.diff(np.sign(way[:, 1] - 2.5)) != 0)]
        out = crossing[crossing[:, 0] < 5.0]
        assert out.size and ((out[:, 0] > 3.0) & (out[:, 0] < 4.0)).all(), crossing


async def test_two_robots_pass_each_other_in_a_corridor(tmp_path: Path) -> None:
    # a corridor 2 m wide and 12 m long between two walls
    corridor = {
        **HALL,
        "walls": HALL["walls"] + [[1.0, 4.0, 13.0, 4.0], [1.0, 6.0, 13.0, 6.0]],
    }
    broker = Broker(tmp_path)
    broker.start()
    robots = [("west", Pose2(0.0, 5.0, 0.0)), ("east", Pose2(14.0, 5.0, math.pi))]
    try:
        async with fleet_sessions(
            from_shapes(corridor, "corridor"), tmp_path, robots, broker.url,
            overrides=ON_BEACONS, sim_settings=SENSORS,
        ) as fleet:  # fmt: skip
            await _all_online(broker, fleet, 2)
            west, east = (
                drive_group(broker.url, GroupGoal(14.0, 5.0, formation="line", step_m=20.0),
                            serials=["west"], timeout_s=180.0),
                drive_group(broker.url, GroupGoal(0.0, 5.0, formation="line", step_m=20.0),
                            serials=["east"], timeout_s=180.0),
            )  # fmt: skip
            results = await asyncio.gather(west, east)
            collisions = [s.sim.body.collisions for s in fleet]
            ends = [(s.sim.body.x_m, s.sim.body.y_m) for s in fleet]
    finally:
        broker.stop()
    assert [r["reached"] for r in results] == [True, True], _why({"runs": results}, tmp_path)
    assert collisions == [0, 0]
    assert math.dist(ends[0], (14.0, 5.0)) < 0.5 and math.dist(ends[1], (0.0, 5.0)) < 0.5
