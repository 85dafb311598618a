"""The pose graph: a drifting loop is pulled back into shape by one loop closure."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam.pose_graph import (
    Edge,
    _graph,
    _jacobian_blocks,
    _residuals,
    graph_distances,
    optimize,
)

W = (20.0, 20.0, 50.0)


def _square(n_side: int = 10, side: float = 5.0) -> list[Pose2]:
    poses = []
    for k in range(4):
        for i in range(n_side):
            heading = k * math.pi / 2
            start = [(0, 0), (side, 0), (side, side), (0, side)][k]
            step = side * i / n_side
            poses.append(
                Pose2(
                    start[0] + step * math.cos(heading),
                    start[1] + step * math.sin(heading),
                    heading,
                )
            )
    return poses


def test_a_loop_closure_removes_accumulated_drift() -> None:
    truth = _square()
    # Odometry turns 1 degree too far at every step: the loop does not close by metres.
    odometry = [truth[0]]
    edges = []
    for i in range(1, len(truth)):
        step = truth[i - 1].between(truth[i])
        wrong = Pose2(step.x, step.y, step.yaw + math.radians(1.0))
        odometry.append(odometry[-1].compose(wrong))
        edges.append(Edge(i - 1, i, tuple(wrong), W))  # type: ignore[arg-type]
    last = len(truth) - 1
    drift = math.hypot(odometry[last].x - truth[last].x, odometry[last].y - truth[last].y)
    assert drift > 1.0
    closing = truth[last].between(truth[0])
    edges.append(Edge(last, 0, tuple(closing), (200.0, 200.0, 500.0)))  # type: ignore[arg-type]
    solved = optimize(np.array([tuple(p) for p in odometry]), edges)
    errors = [math.hypot(s[0] - t.x, s[1] - t.y) for s, t in zip(solved, truth, strict=True)]
    assert max(errors) < 0.3 * drift
    np.testing.assert_array_equal(solved[0], tuple(odometry[0]))  # the anchor does not move


def test_consistent_edges_leave_the_poses_alone() -> None:
    truth = _square(5)
    poses = np.array([tuple(p) for p in truth])
    edges = [
        Edge(i, i + 1, tuple(truth[i].between(truth[i + 1])), W) for i in range(len(truth) - 1)
    ]  # type: ignore[arg-type]
    solved = optimize(poses, edges)
    np.testing.assert_allclose(solved[:, :2], poses[:, :2], atol=1e-6)
    yaw_error = np.remainder(solved[:, 2] - poses[:, 2] + np.pi, 2 * np.pi) - np.pi
    np.testing.assert_allclose(yaw_error, 0.0, atol=1e-6)


def test_the_mapper_finds_loops_when_asked() -> None:
    from navd.bench.synthetic_room import cast
    from navd.geometry import scan_points
    from navd.slam.mapper import ScanMapper
    from navd.slam.settings import MapperSettings

    settings = MapperSettings.defaults(
        loop_closure=True,
        loop_min_gap=10,
        keyframe_distance_m=0.2,
        max_range_m=12.0,
        # The default 20 m window: in this 12 m x 8 m room every old keyframe is near, and
        # they join one pass that ended moments ago. Its part nearest the robot is a lap
        # back, so it is searched (until 4 December it was not, and this test set a 4 m
        # window; docs/slam.md).
        keep_trajectory=True,
    )
    mapper = ScanMapper(settings)
    truth = []
    odom = Pose2(-4.0, -1.0, math.pi / 2)
    for i in range(160):
        angle = 2 * math.pi * i / 80  # twice around the loop
        pose = Pose2(4.0 * math.cos(angle) - 0.5, 2.2 * math.sin(angle) - 0.5, angle + math.pi / 2)
        if truth:
            step = truth[-1].between(pose)
            odom = odom.compose(Pose2(step.x, step.y, step.yaw + math.radians(0.5)))
        truth.append(pose)
        a0, inc, r = cast(pose)
        mapper.add(0.1 * i, scan_points(r, a0, inc, range_min=0.1, range_max=30.0), odom)
    assert mapper.loops.counts.found >= 1
    final = mapper.trajectory()
    errors = [
        math.hypot(*truth[0].between(t).compose(final[0].between(p).inverse())[:2])
        for p, t in zip(final, truth, strict=True)
    ]
    assert max(errors) < 0.1


def test_a_robust_loop_closure_pulls_less_and_bends_the_chain_evenly() -> None:
    truth = [Pose2(float(i), 0.0, 0.0) for i in range(20)]
    poses = np.array([tuple(p) for p in truth])
    chain = [
        Edge(i, i + 1, tuple(truth[i].between(truth[i + 1])), W) for i in range(len(truth) - 1)
    ]  # type: ignore[arg-type]
    wrong = (16.0, 0.0, 0.0)  # the last pose is 19 m from the first, not 16

    def solve(robust: bool) -> npt.NDArray[np.float64]:
        return optimize(poses, [*chain, Edge(0, 19, wrong, W, robust=robust)])

    plain, robust = solve(False), solve(True)
    pulled_plain = 19.0 - plain[19, 0]
    pulled_robust = 19.0 - robust[19, 0]
    assert pulled_plain > 1.0
    assert 0.0 <= pulled_robust < 0.95 * pulled_plain
    # The chain bends evenly: no step takes the loop's pull alone.
    steps = np.diff(robust[:, 0])
    assert steps.max() - steps.min() < 0.01


def test_the_analytic_jacobian_matches_finite_differences() -> None:
    rng = np.random.default_rng(7)
    poses = rng.normal(size=(6, 3)) * (3.0, 3.0, 2.0)
    pairs = [(0, 1), (1, 2), (2, 3), (0, 4), (3, 5), (5, 1)]
    edges = [Edge(i, j, tuple(rng.normal(size=3)), (20.0, 15.0, 50.0)) for i, j in pairs]  # type: ignore[arg-type]
    g = _graph(edges)
    _, rel_x, rel_y = _residuals(poses, g)
    d_i, d_j = _jacobian_blocks(poses, g, rel_x, rel_y)
    h = 1e-6
    for k, (i, j) in enumerate(pairs):
        for node, analytic in ((i, d_i[k]), (j, d_j[k])):
            for c in range(3):
                up, down = poses.copy(), poses.copy()
                up[node, c] += h
                down[node, c] -= h
                numeric = (_residuals(up, g)[0][k] - _residuals(down, g)[0][k]) / (2 * h)
                np.testing.assert_allclose(analytic[:, c], numeric, atol=1e-5)


def test_graph_distances_take_the_shortest_way_loop_edges_included() -> None:
    # Ten poses 1 m apart on a line, the last tied back to the first by a 0.5 m loop edge,
    # and a pose 10 that only a later pose 11 would reach.
    chain = [Edge(i, i + 1, Pose2(1.0, 0.0, 0.0), W) for i in range(9)]
    loop = Edge(0, 9, Pose2(0.3, 0.4, 0.0), W, robust=True)
    later = Edge(10, 11, Pose2(2.0, 0.0, 0.0), W)
    reach = graph_distances([*chain, loop, later], 11, 9)
    # Back along the chain, or across the loop and on from the first pose, whichever is less.
    expected = [min(9.0 - i, 0.5 + i) for i in range(10)]
    np.testing.assert_allclose(reach[:10], expected)
    assert reach.shape == (11,) and math.isinf(reach[10])


def test_graph_distances_take_the_shorter_of_two_edges_and_an_edge_of_no_length() -> None:
    # A pose found again by a loop edge of no length, and two edges between the same poses
    # (a found pose after a load and a loop onto the same old keyframe): the shorter counts,
    # either way round, and a sparse matrix's summing of duplicates must not show.
    chain = [Edge(0, 1, Pose2(1.0, 0.0, 0.0), W), Edge(1, 2, Pose2(1.0, 0.0, 0.0), W)]
    twice = [Edge(0, 3, Pose2(3.0, 0.0, 0.0), W), Edge(3, 0, Pose2(0.0, 1.0, 0.0), W)]
    found = Edge(2, 4, Pose2(0.0, 0.0, 0.0), W, robust=True)
    reach = graph_distances([*chain, *twice, found], 5, 0)
    np.testing.assert_allclose(reach, [0.0, 1.0, 2.0, 1.0, 2.0], atol=1e-6)
