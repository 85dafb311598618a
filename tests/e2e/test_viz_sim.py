"""Watching a drive: the real daemon drives the simulated robot while a viewer speaking the
Foxglove protocol decodes the map, scan, pose and route, checked against the simulator."""

from __future__ import annotations

import asyncio
import contextlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.sim.session import free_port, session
from navd.sim.world import from_shapes
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


async def watch(viewer: FoxgloveClient, latest: dict[str, Any], counts: dict[str, int]) -> None:
    """Keep the latest decoded message of every watched topic."""
    while True:
        topic, _, message = await viewer.receive_any(timeout_s=60.0)
        latest[topic] = message
        counts[topic] = counts.get(topic, 0) + 1


async def test_the_view_of_a_drive_matches_the_simulated_world(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    port = free_port()
    overrides = {"viz": {"port": port}}
    async with session(world, tmp_path, overrides=overrides, lockstep=True, hold_clock=True) as s:
        viewer = await FoxgloveClient.open(port)
        latest: dict[str, Any] = {}
        counts: dict[str, int] = {}
        try:
            await viewer.wait_for_topics(set(WATCHED))
            await viewer.subscribe(*WATCHED)
            watcher = asyncio.create_task(watch(viewer, latest, counts))
            await start(s, world)
            result = await outcome(s)
            await asyncio.sleep(2.0)  # the robot stands at the goal; the view catches up
            watcher.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await watcher
        finally:
            await viewer.close()
        truth = s.sim.truth[-1]
    assert result.state == "reached", result
    assert set(counts) == set(WATCHED), counts
    # The pose the view shows is where the robot really stands.
    pose = latest["/pose"].pose
    assert math.hypot(pose.position.x - truth[1], pose.position.y - truth[2]) <= 0.1
    # The map the view shows is the world's hall.
    grid = latest["/map"]
    cells = np.frombuffer(grid.data, dtype=np.int8).reshape(-1, grid.column_count)
    viewed = ViewedMap(cells, grid.cell_size.x, grid.pose.position.x, grid.pose.position.y)
    assert tolerant_iou(world, viewed, tolerance_m=0.05) >= 0.85
    # The route ends at the goal; the scan is the simulated lidar's, in its frame.
    end = latest["/route"].entities[0].lines[0].points[-1]
    assert world.goal is not None
    assert math.hypot(end.x - world.goal[0], end.y - world.goal[1]) <= 0.05
    scan = latest["/scan"]
    assert scan.frame_id == "laser" and len(scan.ranges) > 100
