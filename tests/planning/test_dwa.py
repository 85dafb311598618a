"""DWA: never a colliding choice, and its look-up structures checked against brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navd.config import NavdConfig
from navd.geometry import IDENTITY, Footprint, Pose2
from navd.planning._dwa_kernels import (
    CHAMFER_RATIO,
    bucket_points,
    chamfer_distance,
    snap_near,
    window_samples,
)
from navd.planning.dwa import SNAP_SLACK_M, DwaSettings, LocalPlanner, Window, arc, path_field
from navd.planning.settings import dwa_settings


def brute_clearance(points: np.ndarray, fp: Footprint, pose: np.ndarray) -> float:
    """[m] smallest distance from any point to the footprint at ``pose`` (independent code)."""
    if points.shape[0] == 0:
        return math.inf
    d = points - pose[:2]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    local = np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
    if fp.kind == 0:
        return float(np.hypot(*local.T).min() - fp.half_length_m)
    # Distance to a rectangle: clamp each point into the box; inside counts negative depth.
    clamped = np.clip(
        local, [-fp.half_length_m, -fp.half_width_m], [fp.half_length_m, fp.half_width_m]
    )
    outside = np.hypot(*(local - clamped).T)
    depth = np.minimum(
        fp.half_length_m - np.abs(local[:, 0]), fp.half_width_m - np.abs(local[:, 1])
    )
    return float(np.where(outside > 0, outside, -depth).min())


def planner(footprint: str) -> tuple[LocalPlanner, DwaSettings]:
    config = NavdConfig.model_validate({"robot": {"footprint": footprint}})
    s = dwa_settings(config.planning, config.robot, config.safety)
    return LocalPlanner(s), s


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    footprint=st.sampled_from(["circle", "rectangle"]),
    count=st.integers(0, 400),
    speed=st.floats(-0.2, 0.5),
    turn=st.floats(-1.5, 1.5),
    backward=st.booleans(),
)
def test_dwa_never_chooses_a_colliding_trajectory(
    seed, footprint, count, speed, turn, backward
) -> None:
    rng = np.random.default_rng(seed)
    lp, s = planner(footprint)
    # Obstacle points anywhere from 0 to 3 m around the robot, some in clusters.
    r = 3.0 * np.sqrt(rng.random(count))
    a = rng.uniform(-math.pi, math.pi, count)
    points = np.column_stack([r * np.cos(a), r * np.sin(a)])
    pose = Pose2(0.0, 0.0, float(rng.uniform(-math.pi, math.pi)))
    path = path_field(np.array([[0.0, 0.0], [3.0, 1.0]]))
    window = Window(0.5, min_speed_mps=0.05, backward=backward)
    choice = lp.choose(pose, (speed, turn), points, path, Pose2(3.0, 1.0, 0.0), window)
    if choice is None:
        return
    # Never closer than the margin, or (to within the point-merging slack) than the robot
    # already is when it starts inside it.
    here = brute_clearance(points, s.footprint, np.array(pose))
    allowed = min(s.margin_m, here - 1e-3 - 2 * SNAP_SLACK_M)
    for state in choice.trajectory:
        assert brute_clearance(points, s.footprint, state) >= allowed - 1e-9


def test_dwa_reports_none_when_boxed_in() -> None:
    lp, _ = planner("rectangle")
    # A ring 0.3 m round a 0.4 x 0.3 m robot: it cannot move or turn without coming closer,
    # so it may only stand still, and when it must move, nothing is left.
    a = np.linspace(-math.pi, math.pi, 720)
    ring = 0.3 * np.column_stack([np.cos(a), np.sin(a)])
    path = path_field(np.array([[0.0, 0.0], [3.0, 0.0]]))
    still = lp.choose(IDENTITY, (0.0, 0.0), ring, path, Pose2(3.0, 0.0, 0.0), Window(0.5))
    assert still is not None and (still.linear_mps, still.angular_radps) == (0.0, 0.0)
    must_move = Window(0.5, min_speed_mps=0.02)
    assert lp.choose(IDENTITY, (0.0, 0.0), ring, path, Pose2(3.0, 0.0, 0.0), must_move) is None


def test_dwa_lets_a_robot_inside_the_margin_move_away() -> None:
    lp, _s = planner("circle")
    wall = np.column_stack([np.full(50, 0.26), np.linspace(-1, 1, 50)])  # 0.06 m ahead: < margin
    path = path_field(np.array([[0.0, 0.0], [-3.0, 0.0]]))
    choice = lp.choose(
        IDENTITY, (0.0, 0.0), wall, path, Pose2(-3.0, 0.0, 0.0), Window(0.5, backward=True)
    )
    assert choice is not None and choice.linear_mps < 0.0


def test_dwa_window_respects_acceleration_and_the_yaw_table() -> None:
    lp, s = planner("circle")
    lp2 = LocalPlanner(s, ((0.0, 1.5), (1.5, 0.0)))  # the top yaw rate: 1.5 - |v|
    v = lp2.velocities((0.3, 0.0), Window(0.5))
    dv = s.linear_accel_mps2 * s.period_s
    assert v[:, 0].min() == pytest.approx(0.3 - dv) and v[:, 0].max() == pytest.approx(0.3 + dv)
    assert (np.abs(v[:, 1]) <= s.angular_accel_radps2 * s.period_s + 1e-12).all()
    assert (np.abs(v[:, 1]) <= 1.5 - np.abs(v[:, 0]) + 1e-12).all()
    backward = lp.velocities((0.0, 0.0), Window(0.5, min_speed_mps=0.1, backward=True))
    assert (backward[:, 0] < 0).all()
    spin = lp.velocities((0.0, 0.0), Window(0.0, rotate_only=True))
    assert (spin[:, 0] == 0).all() and np.ptp(spin[:, 1]) > 0


@pytest.mark.parametrize(("v", "w"), [(0.5, 0.0), (0.3, 1.0), (-0.2, -0.5), (0.0, 1.2)])
def test_arc_matches_small_step_integration(v: float, w: float) -> None:
    poses = arc(Pose2(1.0, -2.0, 0.3), v, w, 0.1, 20)
    x, y, yaw = 1.0, -2.0, 0.3
    h = 1e-4
    for _ in range(20000):  # 2 s
        x += v * h * math.cos(yaw + 0.5 * w * h)
        y += v * h * math.sin(yaw + 0.5 * w * h)
        yaw += w * h
    assert poses[-1] == pytest.approx([x, y, yaw], abs=1e-6)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_chamfer_grid_is_a_lower_bound_on_the_true_distance(seed: int) -> None:
    rng = np.random.default_rng(seed)
    points = rng.uniform(0.0, 2.0, (int(rng.integers(1, 30)), 2))
    res = 0.05
    grid = chamfer_distance(points, 0.0, 0.0, res, 40, 40)
    queries = rng.uniform(0.0, 2.0, (200, 2))
    cells = np.floor(queries / res).astype(int)
    bound = grid[cells[:, 1], cells[:, 0]] / CHAMFER_RATIO - res * math.sqrt(2)
    true = np.hypot(*(queries[:, None, :] - points[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert (bound <= true + 1e-6).all()
    assert (grid[cells[:, 1], cells[:, 0]] <= true * CHAMFER_RATIO + 2 * res * CHAMFER_RATIO).all()


def test_snapped_points_are_within_the_slack_of_every_original() -> None:
    rng = np.random.default_rng(5)
    points = rng.uniform(-3.0, 3.0, (2000, 2))
    snapped = snap_near(points, 0.0, 0.0, 3.0, 0.01)
    nearest = np.hypot(*(points[:, None, :] - snapped[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert nearest.max() <= SNAP_SLACK_M + 1e-12
    assert len(snapped) == len({tuple(c) for c in np.floor(points / 0.01).astype(int)})


def _window_twin(
    v_now: float,
    w_now: float,
    dv: float,
    dw: float,
    lo: float,
    hi: float,
    n_v: int,
    n_w: int,
    min_speed: float,
    rotate_only: bool,
    backward: bool,
    max_yaw: float,
    table: tuple[tuple[float, ...], tuple[float, ...]],
) -> np.ndarray:
    """The dynamic window written with NumPy array calls (how the planner drew it before)."""
    band_hi = hi
    lo, hi = max(lo, v_now - dv), min(hi, v_now + dv)
    if lo > hi:
        lo = hi = v_now - dv if band_hi < v_now - dv else v_now + dv
    speeds = np.linspace(lo, hi, n_v)
    if rotate_only:
        speeds = np.array([min(max(0.0, v_now - dv), v_now + dv)])
    if not backward and min_speed > 0.0:
        keep = np.abs(speeds) >= min(min_speed, abs(hi))
        speeds = speeds[keep] if keep.any() else speeds[-1:]
    caps = np.minimum(max_yaw, np.interp(np.abs(speeds), *table))
    w_lo = np.maximum(-caps, w_now - dw)
    w_hi = np.minimum(caps, w_now + dw)
    stuck = w_lo > w_hi
    w_lo = np.where(stuck, np.clip(w_now, -caps, caps), w_lo)
    w_hi = np.where(stuck, w_lo, w_hi)
    turns = w_lo[:, None] + (w_hi - w_lo)[:, None] * np.linspace(0.0, 1.0, n_w)[None, :]
    return np.column_stack([np.repeat(speeds, n_w), turns.ravel()])


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_the_window_kernel_draws_the_numpy_window_exactly(seed: int) -> None:
    rng = np.random.default_rng(seed)
    backward = bool(rng.random() < 0.2)
    lo, hi = (-0.3, -0.05) if backward else (0.0, float(rng.uniform(0.0, 1.0)))
    args = (
        float(rng.uniform(-0.4, 1.2)),  # the command now: at times out of the band's reach
        float(rng.uniform(-2.5, 2.5)),  # and turning faster than the table allows
        0.1,
        0.4,
        lo,
        hi,
        int(rng.integers(1, 12)),
        int(rng.integers(1, 12)),
        float(rng.choice([0.0, 0.1, 0.6])),
        bool(rng.random() < 0.2),
        backward,
        1.5,
    )
    table = ((0.0, 0.5, 1.0), (1.8, 1.0, 0.4))
    expected = _window_twin(*args, table)
    drawn = window_samples(*args, np.array(table[0]), np.array(table[1]))
    np.testing.assert_array_equal(drawn, expected)


def test_only_points_near_the_robot_are_snapped_each_cell_once() -> None:
    rng = np.random.default_rng(8)
    points = rng.uniform(-4.0, 4.0, (3000, 2))
    points = np.vstack([points, points[:500] + 0.001])  # a second beam in the same cell
    snapped = snap_near(points, 0.5, -0.25, 1.5, 0.01)
    near = points[(np.abs(points[:, 0] - 0.5) <= 1.5) & (np.abs(points[:, 1] + 0.25) <= 1.5)]
    cells = np.unique(np.floor(near / 0.01).astype(np.int64), axis=0)
    in_order = snapped[np.lexsort((snapped[:, 1], snapped[:, 0]))]  # (any order will do)
    np.testing.assert_array_equal(in_order, (cells + 0.5) * 0.01)


def test_buckets_hold_exactly_their_points() -> None:
    rng = np.random.default_rng(3)
    points = rng.uniform(-1.0, 3.0, (300, 2))
    start, order = bucket_points(points, 0.0, 0.0, 0.5, 4, 4)
    for b in range(16):
        r, c = divmod(b, 4)
        inside = np.flatnonzero(
            (np.floor(points[:, 0] / 0.5) == c) & (np.floor(points[:, 1] / 0.5) == r)
        )
        assert sorted(order[start[b] : start[b + 1]]) == sorted(inside)
    assert start[-1] == ((points >= 0) & (points < 2.0)).all(axis=1).sum()
