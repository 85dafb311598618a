"""Watching a drive: the real daemon drives the simulated robot to its goal; a viewer speaking
the Foxglove protocol then decodes the map, scan, pose and route, checked against the
simulator."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.sim import free_port, from_shapes, session
from tests.e2e.test_scenarios import HALL, outcome, start, tolerant_iou
from tests.viz.foxglove_client import FoxgloveClient

pytestmark = pytest.mark.e2e

WATCHED = ("/map", "/scan", "/pose", "/route")


@dataclass(frozen=True)
class ViewedMap:
    """The map as the viewer decoded it, shaped as ``tolerant_iou`` reads a map."""

    occupancy: np.ndarray
    resolution: float
    origin_x: float
    origin_y: float

    def occupancy_percent(self) -> np.ndarray:
        return self.occupancy


async def test_the_view_of_a_drive_matches_the_simulated_world(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    port = free_port()
    overrides = {"viz": {"port": port}}
    async with session(world, tmp_path, overrides=overrides, lockstep=True, hold_clock=True) as s:
        await start(s, world)
        result = await outcome(s)
        # The robot stands at the goal; a viewer connects and gets the whole state at once
        # (the map and route resent on subscribing), then the live scan and pose.
        viewer = await FoxgloveClient.open(port)
        latest: dict[str, Any] = {}
        try:
            await viewer.wait_for_topics(set(WATCHED))
            await viewer.subscribe(*WATCHED)
            while latest.keys() < set(WATCHED):
                topic, _, message = await viewer.receive_any(timeout_s=30.0)
                latest[topic] = message
            _, latest["/pose"] = await viewer.receive("/pose")  # a pose from now, at rest
        finally:
            await viewer.close()
        truth = s.sim.truth[-1]
    assert result.state == "reached", result
    # The pose the view shows is where the robot really stands.
    pose = latest["/pose"].pose
    assert math.hypot(pose.position.x - truth[1], pose.position.y - truth[2]) <= 0.1
    # The map the view shows is the world's hall.
    grid = latest["/map"]
    cells = np.frombuffer(grid.data, dtype=np.int8).reshape(-1, grid.column_count)
    viewed = ViewedMap(cells, grid.cell_size.x, grid.pose.position.x, grid.pose.position.y)
    assert tolerant_iou(world, viewed, tolerance_m=0.05) >= 0.85
    # The route ends at the goal; the scan is the simulated lidar's, at its mount.
    end = latest["/route"].entities[0].lines[0].points[-1]
    assert world.goal is not None
    assert math.hypot(end.x - world.goal[0], end.y - world.goal[1]) <= 0.05
    scan = latest["/scan"]
    assert scan.frame_id == "base_link" and len(scan.ranges) > 100
