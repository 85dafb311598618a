"""The simulator's kernels against independent brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navd.sim._sim_kernels import cast_rays, footprint_contact

RES = 0.05
NO_DISCS = np.empty((0, 3))


def first_entry(grid: np.ndarray, x: float, y: float, angle: float, max_range: float) -> float:
    """The range at which the ray first enters an occupied cell: the slab test against every
    occupied cell's square (independent of any grid walk)."""
    dx, dy = math.cos(angle), math.sin(angle)
    best = math.inf
    for r, c in np.argwhere(grid):
        lo_t, hi_t = -math.inf, math.inf
        for origin, d, lo, hi in ((x, dx, c * RES, (c + 1) * RES), (y, dy, r * RES, (r + 1) * RES)):
            if abs(d) < 1e-15:
                if not lo <= origin < hi:
                    lo_t, hi_t = math.inf, -math.inf
                continue
            t0, t1 = (lo - origin) / d, (hi - origin) / d
            lo_t, hi_t = max(lo_t, min(t0, t1)), min(hi_t, max(t0, t1))
        if lo_t <= hi_t and hi_t >= 0:
            best = min(best, max(lo_t, 0.0))
    return best if best <= max_range else math.inf


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_rays_stop_where_they_first_enter_an_occupied_cell(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = rng.random((40, 40)) < 0.05
    x, y = rng.uniform(0.2, 1.8, 2)
    grid[math.floor(y / RES), math.floor(x / RES)] = False
    angles = rng.uniform(-math.pi, math.pi, 12)
    angles[:4] = [0.0, math.pi / 2, math.pi, -math.pi / 2]  # along the grid lines too
    ranges = cast_rays(grid, 0.0, 0.0, RES, x, y, angles, 3.0, NO_DISCS)
    for angle, got in zip(angles, ranges, strict=True):
        expected = first_entry(grid, x, y, angle, 3.0)
        if math.isinf(expected):
            assert math.isinf(got)
        else:
            assert got == pytest.approx(expected, abs=1e-9)


def test_rays_hit_discs_at_their_edge() -> None:
    grid = np.zeros((10, 10), bool)
    discs = np.array([[3.0, 0.0, 0.5], [0.0, -2.0, 0.25]])
    ranges = cast_rays(
        grid, -5.0, -5.0, 1.0, 0.0, 0.0, np.array([0.0, -math.pi / 2, math.pi]), 10.0, discs
    )
    assert ranges[0] == pytest.approx(2.5)
    assert ranges[1] == pytest.approx(1.75)
    assert math.isinf(ranges[2])


@pytest.mark.parametrize(
    ("kind", "pose", "expected"),
    [
        (0, (1.0, 1.0, 0.0), 0.5 - 0.2),  # circle r 0.2, obstacle cell centre 0.5 m to the right
        (1, (1.0, 1.0, 0.0), 0.5 - 0.2),  # rectangle 0.4 x 0.3 facing it: front edge 0.2 out
        (1, (1.0, 1.0, math.pi / 2), 0.5 - 0.15),  # turned: its side faces it
        (0, (1.4, 1.0, 0.0), -0.1),  # overlapping by 0.1 m
    ],
)
def test_footprint_contact_is_the_signed_distance(kind, pose, expected) -> None:
    grid = np.zeros((60, 60), bool)
    grid[int(1.0 / RES), int(1.5 / RES)] = True  # cell centre (1.525, 1.025)
    centre = (1.525, 1.025)
    pose = (pose[0] + centre[0] - 1.5, pose[1] + centre[1] - 1.0, pose[2])
    half = (0.2, 0.2) if kind == 0 else (0.2, 0.15)
    got = footprint_contact(grid, 0.0, 0.0, RES, *pose, kind, *half, NO_DISCS)
    assert got == pytest.approx(expected, abs=1e-9)


def test_footprint_contact_sees_discs() -> None:
    grid = np.zeros((20, 20), bool)
    discs = np.array([[0.5, 0.5 + 0.6, 0.3]])
    got = footprint_contact(grid, 0.0, 0.0, RES, 0.5, 0.5, 0.0, 0, 0.2, 0.2, discs)
    assert got == pytest.approx(0.6 - 0.3 - 0.2)
