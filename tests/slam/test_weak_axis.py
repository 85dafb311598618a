"""The weak axis of a scan: along a corridor, nowhere in particular in a room."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import pytest

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2, scan_points
from navd.slam.matcher import WEAK_AXIS_RATIO
from navd.slam.voxel import voxel_downsample
from navd.slam.weak_axis import MIN_SEGMENTS, weak_axis

VOXEL_M = 0.1  # the default slam.voxel_size_m


def _corridor_scan(heading: float) -> npt.NDArray[np.float64]:
    """A corridor 2 m wide whose length runs at ``heading`` [rad] in the scan's frame,
    seen to 8 m, as the matcher gets it (0.1 m voxels, beam order)."""
    angles = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    s = np.sin(angles - heading)
    with np.errstate(divide="ignore"):
        ranges = np.abs(1.0 / s)
    ranges[ranges > 8.0] = np.inf
    hits = scan_points(
        ranges, float(angles[0]), float(angles[1] - angles[0]), range_min=0.1, range_max=30.0
    ).hits
    return voxel_downsample(hits, VOXEL_M)


@pytest.mark.parametrize("heading", [0.0, 0.4, math.pi / 2, -2.0])
def test_a_corridor_is_weak_along_its_length(heading: float) -> None:
    axis = weak_axis(_corridor_scan(heading), VOXEL_M)
    assert axis is not None
    # nothing but the two walls: nothing holds the scan along them
    assert axis.ratio < 0.02
    along = abs(axis.x * math.cos(heading) + axis.y * math.sin(heading))
    assert along == pytest.approx(1.0, abs=1e-3)


def test_a_room_seen_whole_has_no_weak_axis_to_speak_of() -> None:
    a0, inc, ranges = cast(Pose2(0.3, -0.2, 0.4))
    hits = scan_points(ranges, a0, inc, range_min=0.1, range_max=30.0).hits
    axis = weak_axis(voxel_downsample(hits, VOXEL_M), VOXEL_M)
    assert axis is not None
    assert axis.ratio > WEAK_AXIS_RATIO  # the matcher adds no pull there


def test_a_square_holds_both_directions_alike() -> None:
    side = np.linspace(-2.0, 2.0, 41)
    square = np.concatenate(
        [
            np.column_stack([side, np.full(41, -2.0)]),
            np.column_stack([np.full(41, 2.0), side]),
            np.column_stack([side[::-1], np.full(41, 2.0)]),
            np.column_stack([np.full(41, -2.0), side[::-1]]),
        ]
    )
    axis = weak_axis(square, VOXEL_M)
    assert axis is not None
    assert axis.ratio == pytest.approx(1.0, abs=0.05)


def test_the_axis_turns_with_the_frame() -> None:
    axis = weak_axis(_corridor_scan(0.3), VOXEL_M)
    assert axis is not None
    turned = axis.rotated(0.4)  # not a right angle: turned the wrong way it lies along -0.1
    along = abs(turned.x * math.cos(0.7) + turned.y * math.sin(0.7))
    assert along == pytest.approx(1.0, abs=1e-3)
    assert turned.ratio == axis.ratio


def test_too_few_surface_segments_give_no_axis() -> None:
    # Points a metre apart are no surface: a sparse scan, a few far posts.
    posts = np.column_stack([np.arange(30.0), np.zeros(30)])
    assert weak_axis(posts, VOXEL_M) is None
    # ... unless the points were thinned that coarsely: then they are a wall along x
    wall = weak_axis(posts, 1.0)
    assert wall is not None and abs(wall.x) == pytest.approx(1.0)
    few = np.column_stack([0.1 * np.arange(MIN_SEGMENTS), np.zeros(MIN_SEGMENTS)])
    assert weak_axis(few, VOXEL_M) is None  # MIN_SEGMENTS points make one segment fewer
    enough = np.column_stack([0.1 * np.arange(MIN_SEGMENTS + 1), np.zeros(MIN_SEGMENTS + 1)])
    assert weak_axis(enough, VOXEL_M) is not None
    assert weak_axis(np.zeros((0, 2)), VOXEL_M) is None
    assert weak_axis(np.zeros((1, 2)), VOXEL_M) is None
    # Readings that are not numbers or repeat a point are no surface either.
    broken = enough.copy()
    broken[3] = np.nan
    assert weak_axis(broken, VOXEL_M) is None  # two segments lost: fewer than needed
