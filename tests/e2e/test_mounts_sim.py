"""Two lidars on one robot: the real daemon maps and drives the simulated hall with two
half-circle lidars back to back (the rear one upside down) as it does with one all-around
lidar, each scan read through its own mount."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy import ndimage

from navd.sim import from_shapes, session
from navd.slam import load_map
from navd.wire import SaveMapFrame
from tests.drivers.conftest import until
from tests.e2e.test_scenarios import HALL, outcome, start, tolerant_iou

pytestmark = pytest.mark.e2e

BACK_TO_BACK = {
    "mounts": {
        "lidars": {
            "front": {"x_m": 0.1, "yaw_rad": 0.0},
            "rear": {"x_m": -0.1, "yaw_rad": 3.1416, "upside_down": True},
        }
    }
}


def agreement_iou(a: Any, b: Any, tolerance_m: float) -> float:
    """IoU = TP / (TP + FP + FN) of map ``a``'s obstacle cells against map ``b``'s, each
    cell matched within ``tolerance_m`` (two drives never put a wall in the same cell)."""
    res = a.resolution
    assert b.resolution == res
    # both maps on one grid spanning the two
    x0, y0 = min(a.origin_x, b.origin_x), min(a.origin_y, b.origin_y)
    shape = (
        max(round((m.origin_y - y0) / res) + m.occupancy_percent().shape[0] for m in (a, b)),
        max(round((m.origin_x - x0) / res) + m.occupancy_percent().shape[1] for m in (a, b)),
    )

    def placed(m: Any) -> Any:
        grid = np.zeros(shape, bool)
        r, c = round((m.origin_y - y0) / res), round((m.origin_x - x0) / res)
        occupied = m.occupancy_percent() >= 65
        grid[r : r + occupied.shape[0], c : c + occupied.shape[1]] = occupied
        return grid

    mine, theirs = placed(a), placed(b)
    reach = max(1, math.ceil(tolerance_m / res))
    near_theirs = ndimage.binary_dilation(theirs, iterations=reach)
    near_mine = ndimage.binary_dilation(mine, iterations=reach)
    true_positive = int((mine & near_theirs).sum())
    false_positive = int((mine & ~near_theirs).sum())
    false_negative = int((theirs & ~near_mine).sum())
    return true_positive / (true_positive + false_positive + false_negative)


async def _drive_and_map(tmp_path: Path, name: str, **options: Any) -> Any:
    world = from_shapes(HALL, "hall")
    async with session(world, tmp_path / name, lockstep=True, hold_clock=True, **options) as s:
        await start(s, world)
        result = await outcome(s)
        s.control.send(SaveMapFrame(name="hall"))
        await until((s.maps / "hall.yaml").exists, 5.0)
        connected = set(s.sim.connected)
    assert result.state == "reached", result
    assert s.sim.body.collisions == 0
    return load_map(tmp_path / name / "maps" / "hall.yaml"), connected, world


async def test_two_half_lidars_back_to_back_map_as_one_all_around_lidar(tmp_path: Path) -> None:
    single, _, world = await _drive_and_map(tmp_path, "single")
    double, connected, _ = await _drive_and_map(
        tmp_path,
        "double",
        overrides=BACK_TO_BACK,
        sim_settings={"lidar_fov_rad": math.pi},
    )
    assert {"front", "rear"} <= connected
    assert tolerant_iou(world, double, tolerance_m=0.05) >= 0.85
    assert agreement_iou(double, single, tolerance_m=0.05) >= 0.9
    # Behind the start (x < -0.5) only the rear lidar ever looked: the wall there is mapped.
    occupied = double.occupancy_percent() >= 65
    _, cols = np.nonzero(occupied)
    xs = double.origin_x + (cols + 0.5) * double.resolution
    assert np.count_nonzero(np.abs(xs + 1.0) <= 0.1) >= 30  # the back wall at x = -1
