"""Loop closure: a drifted revisit is found on the old pass's map, a look-alike is not."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2, ScanPoints, scan_points
from navd.slam.keyframe import Keyframe
from navd.slam.loop_closure import (
    LOOP_FAR_EVERY_KEYFRAMES,
    LoopCandidate,
    LoopCloser,
    passes,
    path_lengths,
)
from navd.slam.mapper import ScanMapper
from navd.slam.pose_graph import Edge
from navd.slam.settings import MapperSettings

# A corridor 2 m wide and 60 m long with bare walls: every stretch of it looks the same.
CORRIDOR = np.array([[-30.0, -1.0, 30.0, -1.0], [-30.0, 1.0, 30.0, 1.0]])


def _scan(pose: Pose2, walls: np.ndarray | None = None) -> ScanPoints:
    a0, inc, r = cast(pose) if walls is None else cast(pose, 360, walls)
    return scan_points(r, a0, inc, range_min=0.1, range_max=30.0)


def _ellipse(n: int, turn0: float = 0.0) -> list[Pose2]:
    """Poses 0.3 m apart on an ellipse through the room's free space, facing along it."""
    out = []
    for i in range(n):
        a = turn0 + 2 * math.pi * i / 70
        out.append(Pose2(4.0 * math.cos(a) - 0.5, 2.6 * math.sin(a) - 0.5, a + math.pi / 2))
    return out


def _detour(start: Pose2, length_m: float) -> list[Keyframe]:
    """Keyframes 1 m apart out from ``start`` and back, ``length_m`` of path that mapped
    nothing (as when the robot was lost)."""
    half = round(length_m / 2)
    out = [Pose2(start.x + i, start.y, 0.0) for i in range(1, half + 1)]
    out += [Pose2(start.x + half - i, start.y, math.pi) for i in range(1, half + 1)]
    return [Keyframe(0.0, p, None, mapped=False) for p in out]


def _chain(keyframes: list[Keyframe]) -> list[Edge]:
    """The tracked edges between consecutive keyframes, as the mapper makes them."""
    w = (10.0, 10.0, 30.0)
    return [
        Edge(i, i + 1, a.pose.between(b.pose), w)
        for i, (a, b) in enumerate(itertools.pairwise(keyframes))
    ]


def _search(closer: LoopCloser, keyframes: list[Keyframe]) -> list[LoopCandidate]:
    """The newest keyframe searched for, the keyframes tied by their chain alone."""
    return closer.search(keyframes, _chain(keyframes), len(keyframes) - 1)


def test_path_lengths_add_up_the_distance_between_keyframes() -> None:
    poses = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 1.0], [3.0, 4.0, 2.0], [3.0, 6.0, 0.0]])
    np.testing.assert_allclose(path_lengths(poses), [0.0, 5.0, 5.0, 7.0])


def test_passes_split_where_keyframe_indices_jump() -> None:
    runs = passes(np.array([1, 2, 4, 20, 22, 90]), join=5)
    assert [r.tolist() for r in runs] == [[1, 2, 4], [20, 22], [90]]
    assert passes(np.array([], dtype=np.int64), join=5) == []


def test_a_revisit_metres_off_after_a_long_detour_is_found_where_it_really_is() -> None:
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    first = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    detour = _detour(first[-1].pose, 120.0)
    # Back in the room after 120 m, the estimate has drifted 2.5 m and 4 degrees.
    drift = Pose2(1.5, -2.0, math.radians(4.0))
    truth = _ellipse(12, turn0=1.0)
    revisit = [Keyframe(0.0, drift.compose(t), _scan(t)) for t in truth]
    keyframes = first + detour + revisit
    closer = LoopCloser(settings)
    found = _search(closer, keyframes)
    assert len(found) == 1
    loop = found[0]
    assert loop.new == len(keyframes) - 1 and 0 <= loop.old < len(first)
    assert math.hypot(loop.pose.x - truth[-1].x, loop.pose.y - truth[-1].y) < 0.05
    assert abs(math.remainder(loop.pose.yaw - truth[-1].yaw, 2 * math.pi)) < 0.01
    assert loop.score >= settings.loop_min_score
    assert (closer.counts.checks, closer.counts.found) == (1, 1)


def _stay_near(length_m: float) -> list[Keyframe]:
    """Keyframes 0.3 m apart driving back and forth along a 4 m line 5 m south of the room's
    centre for ``length_m`` of steps (a little less path: the turns cut corners), seeing
    nothing: near the room, but never in it."""
    step_m, span_m = 0.3, 4.0
    out = []
    for i in range(round(length_m / step_m)):
        along = (i * step_m) % (2 * span_m)
        x = -2.75 + (along if along <= span_m else 2 * span_m - along)
        out.append(
            Keyframe(0.0, Pose2(x, -5.3, 0.0), ScanPoints(np.zeros((0, 2)), np.zeros((0, 2))))
        )
    return out


def _revisit_after(before: list[Keyframe]) -> tuple[list[Keyframe], Pose2]:
    """``before``, a 20 m detour, and 12 keyframes back in the room 3 m off on both axes and
    4 degrees; and the last one's true pose."""
    drift = Pose2(3.0, -3.0, math.radians(4.0))
    truth = _ellipse(12, turn0=1.0)
    revisit = [Keyframe(0.0, drift.compose(t), _scan(t)) for t in truth]
    return before + _detour(before[-1].pose, 20.0) + revisit, truth[-1]


def test_a_long_pass_is_searched_as_far_as_the_path_since_its_part_nearest_the_robot() -> None:
    # The robot mapped the room, stayed near it for 110 m of path (seeing nothing), left,
    # and came back 3 m off. The pass (the room and the stay) was left 32 m of path ago:
    # counted from there the window is 2 m. Its part nearest the robot, the room, was driven
    # 150-170 m ago: counted from there the window is 4 m (the cap), and the room is found.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    room = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    keyframes, truth = _revisit_after(room + _stay_near(115.0))
    closer = LoopCloser(settings)
    found = _search(closer, keyframes)
    assert closer.counts.checks == 1  # the room and the stay near it are one pass
    assert len(found) == 1
    assert math.hypot(found[0].pose.x - truth.x, found[0].pose.y - truth.y) < 0.05
    assert 0 <= found[0].old < len(room)


def test_a_long_pass_whose_nearest_part_was_driven_last_keeps_a_narrow_window() -> None:
    # The same places in the other order: the stay first, the room last. The pass began
    # 170 m ago, but the room, its part nearest the robot, was driven 25-45 m ago: the
    # window stays under 2.7 m, and a 3 m jump after so little path is not believed.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    room = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    keyframes, truth = _revisit_after(_stay_near(115.0) + room)
    closer = LoopCloser(settings)
    found = _search(closer, keyframes)
    assert closer.counts.checks == 1
    assert all(math.hypot(f.pose.x - truth.x, f.pose.y - truth.y) > 1.0 for f in found)


def test_a_place_passed_again_in_one_unbroken_pass_is_searched() -> None:
    # A lap of the room and 30 keyframes more in one go, those 0.6 m off on both axes and 2
    # degrees. The old keyframes near the robot are one pass, the whole way round up to the
    # newest ``loop_min_gap`` keyframes, and it ends only 12 m of path ago; its part nearest
    # the robot was driven a lap (21 m) ago, so it is searched (as the way out and back of a
    # dead-end corridor is).
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    lap = _ellipse(100)
    drift = Pose2(0.6, -0.6, math.radians(2.0))
    keyframes = [Keyframe(0.0, p, _scan(p)) for p in lap[:70]]
    keyframes += [Keyframe(0.0, drift.compose(p), _scan(p)) for p in lap[70:]]
    closer = LoopCloser(settings)
    found = _search(closer, keyframes)
    assert closer.counts.checks == 1
    assert len(found) == 1
    assert math.hypot(found[0].pose.x - lap[-1].x, found[0].pose.y - lap[-1].y) < 0.05
    assert 20 <= found[0].old <= 40  # the first lap's keyframes at the same place


def test_a_pass_the_graph_already_ties_to_the_robot_is_searched_in_a_narrow_window() -> None:
    # The revisit of the first test, 3 m off after a 120 m detour: alone the window is 4 m
    # (the cap) and the room is found. With a loop edge tying the revisit's first keyframe
    # to the room, the room's keyframe nearest the robot is at most 14 m away through the
    # graph, the window is 2 m (its least), and a 3 m jump is not believed.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    room = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    keyframes, truth = _revisit_after(room)
    keyframes = room + _detour(room[-1].pose, 120.0) + keyframes[-12:]
    chain = _chain(keyframes)
    k = len(keyframes) - 1
    found = LoopCloser(settings).search(keyframes, chain, k)
    assert len(found) == 1
    assert math.hypot(found[0].pose.x - truth.x, found[0].pose.y - truth.y) < 0.05
    first = k - 11
    seen = room[11].pose.between(_ellipse(1, turn0=1.0)[0])  # where it truly is: 0.05 m on
    tie = Edge(11, first, seen, (10.0, 10.0, 30.0), robust=True)
    found = LoopCloser(settings).search(keyframes, [*chain, tie], k)
    assert all(math.hypot(f.pose.x - truth.x, f.pose.y - truth.y) > 1.0 for f in found)


def test_a_revisit_whose_scans_saw_nothing_is_not_searched_and_does_not_fail() -> None:
    # Back in the room, but the newest scans have no hits (an 8 m lidar in a wide hall):
    # there is nothing to match, and the search says so instead of failing on no points.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    first = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    detour = _detour(first[-1].pose, 120.0)
    blind = ScanPoints(np.zeros((0, 2)), np.zeros((0, 2)))
    revisit = [Keyframe(0.0, t, blind) for t in _ellipse(12, turn0=1.0)]
    keyframes = first + detour + revisit
    closer = LoopCloser(settings)
    assert _search(closer, keyframes) == []
    assert (closer.counts.checks, closer.counts.found) == (1, 0)


def test_the_window_grows_with_the_path_so_a_short_detour_cannot_jump_metres() -> None:
    # A 3 m error on both axes after only 30 m of path is not believed: the window is 2 m.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    first = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    drift = Pose2(3.0, -3.0, math.radians(4.0))
    truth = _ellipse(12, turn0=1.0)
    revisit = [Keyframe(0.0, drift.compose(t), _scan(t)) for t in truth]
    keyframes = first + _detour(first[-1].pose, 30.0) + revisit
    for loop in _search(LoopCloser(settings), keyframes):
        assert math.hypot(loop.pose.x - truth[-1].x, loop.pose.y - truth[-1].y) > 1.0


def test_a_passage_that_looks_the_same_metres_further_on_is_not_a_loop() -> None:
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=6.0, loop_search_xy_m=4.0)
    first = [Keyframe(0.0, p, _scan(p, CORRIDOR)) for p in _line(-15.0, 15.0)]
    detour = _detour(first[-1].pose, 150.0)
    revisit = [Keyframe(0.0, p, _scan(p, CORRIDOR)) for p in _line(-3.0, 0.0)]
    keyframes = first + detour + revisit
    closer = LoopCloser(settings)
    assert _search(closer, keyframes) == []
    assert closer.counts.checks == 1 and closer.counts.ambiguous == 1


# The corridor narrowed to 0.6 m every 3 m by a fin from each wall: any stretch looks like the
# one 3 m on, and nothing like the one 1-2 m on.
FINS = np.array(
    [[x, side, x, side * 0.3] for x in np.arange(-30.0, 30.1, 3.0) for side in (-1.0, 1.0)]
)
DOORS = np.vstack([CORRIDOR, FINS])


def test_a_look_alike_the_robot_could_have_drifted_to_is_doubted_however_narrow_the_window() -> (
    None
):
    # Back in the corridor of fins after a 150 m detour, tied to it by a loop the graph
    # already holds: through the graph the pass is near and the window 2 m wide, and within
    # it the true place is the only fit. But by its tracking alone the robot could be 4 m
    # off (the cap), where the stretch 3 m on fits as well: the match is doubted.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=6.0, loop_search_xy_m=4.0)
    first = [Keyframe(0.0, p, _scan(p, DOORS)) for p in _line(-15.0, 15.0)]
    detour = _detour(first[-1].pose, 150.0)
    revisit = [Keyframe(0.0, p, _scan(p, DOORS)) for p in _line(-3.0, 0.0)]
    keyframes = first + detour + revisit
    k = len(keyframes) - 1
    near = next(i for i, f in enumerate(first) if abs(f.pose.x + 3.0) < 0.01)
    tie = Edge(near, k - len(revisit) + 1, Pose2(0.0, 0.0, 0.0), (10.0, 10.0, 30.0), True)
    closer = LoopCloser(settings)
    assert closer.search(keyframes, [*_chain(keyframes), tie], k) == []
    assert closer.counts.checks == 1 and closer.counts.ambiguous == 1


def _line(x0: float, x1: float) -> list[Pose2]:
    return [Pose2(float(x), 0.0, 0.0) for x in np.arange(x0, x1 + 1e-9, 0.3)]


def test_with_loop_closure_a_scan_that_does_not_match_joins_the_graph_but_not_the_map() -> None:
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0)
    mapper = ScanMapper(settings)
    start = Pose2(0.0, 0.0, 0.0)
    mapper.add(0.0, _scan(start), start)
    before = mapper.grid.to_array()
    # Odometry says 0.5 m on; the scan was taken 1.5 m on and turned 0.6 rad: no match.
    result = mapper.add(1.0, _scan(Pose2(1.5, 0.0, 0.6)), Pose2(0.5, 0.0, 0.0))
    assert not result.matched and not result.keyframe
    assert mapper.counts.weak_matches == 1
    assert [k.mapped for k in mapper.keyframes] == [True, False]
    assert mapper.keyframes[-1].pose == result.pose
    np.testing.assert_array_equal(mapper.grid.to_array(), before)


def test_new_settings_reach_the_loop_search() -> None:
    mapper = ScanMapper(MapperSettings.defaults(loop_closure=True, max_range_m=12.0))
    mapper.configure(
        MapperSettings.defaults(loop_closure=True, max_range_m=30.0, loop_search_xy_m=8.0)
    )
    assert mapper.loops.settings.loop_search_xy_m == 8.0
    assert mapper.loops.fine.reach_m == 15.0  # half the longest range: the rotation step


def _far_revisit(jump: Pose2) -> tuple[list[Keyframe], int, list[Pose2]]:
    """The room mapped, a 120 m detour, and 24 keyframes back in it 2.4-2.6 m off on each
    axis and 4 degrees (the last 14 of them moved by ``jump`` more, as a tracking slip
    would); the index of the first keyframe back and their true poses."""
    first = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    detour = _detour(first[-1].pose, 120.0)
    drift = Pose2(2.6, -2.4, math.radians(4.0))
    truth = _ellipse(24, turn0=1.0)
    back = [Keyframe(0.0, drift.compose(t), _scan(t)) for t in truth[:10]]
    back += [Keyframe(0.0, jump.compose(drift.compose(t)), _scan(t)) for t in truth[10:]]
    return first + detour + back, len(first) + len(detour), truth


def _search_at(closer: LoopCloser, keyframes: list[Keyframe], k: int) -> list[LoopCandidate]:
    """Keyframe ``k`` searched for, with the keyframes up to it tied by their chain alone."""
    return closer.search(keyframes[: k + 1], _chain(keyframes[: k + 1]), k)


def test_a_revisit_beyond_the_window_cap_is_used_once_a_second_match_agrees() -> None:
    # The cap is 2 m, the robot is back 2.4-2.6 m off on each axis after 120 m of path (the
    # path asks for a window of 8 m): the match beyond the cap is held until a keyframe 5
    # later is found where the first match and the tracking between them put it; then both
    # are returned. Only every fifth keyframe is searched beyond the cap.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=2.0)
    keyframes, start, truth = _far_revisit(Pose2(0.0, 0.0, 0.0))
    assert start % LOOP_FAR_EVERY_KEYFRAMES == 0
    closer = LoopCloser(settings)
    assert _search_at(closer, keyframes, start + 5) == []
    assert (closer.counts.far_held, closer.counts.far_confirmed) == (1, 0)
    assert _search_at(closer, keyframes, start + 7) == []
    assert closer.counts.far_held == 1  # not searched beyond the cap
    found = _search_at(closer, keyframes, start + 10)
    assert [f.new for f in found] == [start + 5, start + 10]
    for loop in found:
        t = truth[loop.new - start]
        assert math.hypot(loop.pose.x - t.x, loop.pose.y - t.y) < 0.05
        assert 0 <= loop.old < 70
    assert closer.counts.far_confirmed == 1


@pytest.mark.parametrize(
    "slip",
    [Pose2(0.6, 0.3, 0.0), Pose2(0.0, 0.0, math.radians(3.5))],
    ids=["0.67 m", "3.5 degrees"],
)
def test_a_far_match_the_tracking_since_disagrees_with_confirms_nothing(slip: Pose2) -> None:
    # As above, but between the two matches the tracking slipped (0.67 m, or 3.5 degrees
    # about the room's centre: 0.2 m or less where the robot is): the second match is not
    # where the first and the tracking put it, so neither is used; both are held.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=2.0)
    keyframes, start, _ = _far_revisit(slip)
    closer = LoopCloser(settings)
    assert _search_at(closer, keyframes, start + 5) == []
    assert _search_at(closer, keyframes, start + 20) == []  # its query all after the slip
    assert (closer.counts.far_held, closer.counts.far_confirmed) == (2, 0)


def test_a_held_far_match_is_confirmed_and_returned_as_the_graph_has_moved_it() -> None:
    # Between the two matches a re-solve moved every keyframe alike: the held match is
    # compared, and returned, where the graph has moved its old keyframe to.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=2.0)
    keyframes, start, truth = _far_revisit(Pose2(0.0, 0.0, 0.0))
    closer = LoopCloser(settings)
    assert _search_at(closer, keyframes, start + 5) == []
    move = Pose2(0.4, -0.3, 0.05)
    moved = [Keyframe(f.stamp, move.compose(f.pose), f.scan, f.mapped) for f in keyframes]
    found = _search_at(closer, moved, start + 10)
    assert [f.new for f in found] == [start + 5, start + 10]
    for loop in found:
        t = move.compose(truth[loop.new - start])
        assert math.hypot(loop.pose.x - t.x, loop.pose.y - t.y) < 0.05


def test_within_the_cap_a_loop_is_used_at_once_and_nothing_is_held() -> None:
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    keyframes, start, _ = _far_revisit(Pose2(0.0, 0.0, 0.0))
    closer = LoopCloser(settings)
    assert [f.new for f in _search_at(closer, keyframes, start + 1)] == [start + 1]
    assert closer.counts.far_held == 0 and closer.held == []


def test_a_far_match_on_another_old_pass_confirms_nothing() -> None:
    # Two far matches that agree in the map but lie on old keyframes 50 apart, five new
    # keyframes apart: not one old pass passed again, so no confirmation.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=2.0)
    frames = [Keyframe(0.0, Pose2(0.3 * i, 0.0, 0.0), None, mapped=False) for i in range(120)]
    closer = LoopCloser(settings)
    shift = Pose2(25.0, 1.0, 0.1)  # where the far matches put the robot, from its estimate
    first = LoopCandidate(10, 100, shift.compose(frames[100].pose), 0.8)
    assert closer._confirmed(frames, first) == []
    elsewhere = LoopCandidate(60, 105, shift.compose(frames[105].pose), 0.8)
    assert closer._confirmed(frames, elsewhere) == []
    same_pass = LoopCandidate(16, 110, shift.compose(frames[110].pose), 0.8)
    assert [c.new for c in closer._confirmed(frames, same_pass)] == [100, 110]


def test_a_confirmed_far_loop_ties_each_match_to_its_own_keyframe() -> None:
    # The mapper gets the held match (an earlier keyframe) and the new one together: each
    # edge goes from the old keyframe to the keyframe that was matched, measured as matched.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0)
    mapper = ScanMapper(settings)
    mapper.keyframes = [
        Keyframe(float(i), Pose2(0.3 * i, 0.0, 0.0), None, mapped=False) for i in range(60)
    ]
    mapper.edges = _chain(mapper.keyframes)
    held = LoopCandidate(3, 50, Pose2(1.0, 0.5, 0.02), 0.8)
    far = LoopCandidate(5, 59, Pose2(3.6, 0.6, 0.03), 0.8)
    chain = len(mapper.edges)
    old = {i: mapper.keyframes[i].pose for i in (3, 5)}

    class Found:
        def search(self, *args: object) -> list[LoopCandidate]:
            return [held, far]

    mapper.loops = Found()  # type: ignore[assignment]
    mapper._close_loop(59)
    loops = mapper.edges[chain:]
    assert [(e.i, e.j) for e in loops] == [(3, 50), (5, 59)]
    for edge, loop in zip(loops, (held, far), strict=True):
        want = old[loop.old].between(loop.pose)
        assert (edge.z.x, edge.z.y, edge.z.yaw) == pytest.approx((want.x, want.y, want.yaw))
