"""Loop closure: a drifted revisit is found on the old pass's map, a look-alike is not."""

from __future__ import annotations

import math

import numpy as np

from navd.bench.room import cast
from navd.geometry.pose import Pose2
from navd.geometry.scan import ScanPoints, scan_points
from navd.slam.keyframe import Keyframe
from navd.slam.loop_closure import LoopCloser, passes, path_lengths
from navd.slam.mapper import ScanMapper
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
    found = closer.search(keyframes, len(keyframes) - 1)
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
    """``before``, a 20 m detour, and 12 keyframes back in the room 2.5 m and 4 degrees off;
    and the last one's true pose."""
    drift = Pose2(1.5, -2.0, math.radians(4.0))
    truth = _ellipse(12, turn0=1.0)
    revisit = [Keyframe(0.0, drift.compose(t), _scan(t)) for t in truth]
    return before + _detour(before[-1].pose, 20.0) + revisit, truth[-1]


def test_a_long_pass_is_searched_as_far_as_the_path_since_its_part_nearest_the_robot() -> None:
    # The robot mapped the room, stayed near it for 110 m of path (seeing nothing), left,
    # and came back 2.5 m off. The pass (the room and the stay) was left 32 m of path ago:
    # counted from there the window is 1 m. Its part nearest the robot, the room, was driven
    # 150-170 m ago: counted from there the window is 4 m (the cap), and the room is found.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    room = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    keyframes, truth = _revisit_after(room + _stay_near(115.0))
    closer = LoopCloser(settings)
    found = closer.search(keyframes, len(keyframes) - 1)
    assert closer.counts.checks == 1  # the room and the stay near it are one pass
    assert len(found) == 1
    assert math.hypot(found[0].pose.x - truth.x, found[0].pose.y - truth.y) < 0.05
    assert 0 <= found[0].old < len(room)


def test_a_long_pass_whose_nearest_part_was_driven_last_keeps_a_narrow_window() -> None:
    # The same places in the other order: the stay first, the room last. The pass began
    # 170 m ago, but the room, its part nearest the robot, was driven 25-45 m ago: the
    # window stays under 1.4 m, and a 2.5 m jump after so little path is not believed.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    room = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    keyframes, truth = _revisit_after(_stay_near(115.0) + room)
    closer = LoopCloser(settings)
    found = closer.search(keyframes, len(keyframes) - 1)
    assert closer.counts.checks == 1
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
    assert closer.search(keyframes, len(keyframes) - 1) == []
    assert (closer.counts.checks, closer.counts.found) == (1, 0)


def test_the_window_grows_with_the_path_so_a_short_detour_cannot_jump_metres() -> None:
    # The same 2.5 m error after only 30 m of path is not believed: the window is 1 m wide.
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=12.0, loop_search_xy_m=4.0)
    first = [Keyframe(0.0, p, _scan(p)) for p in _ellipse(70)]
    drift = Pose2(1.5, -2.0, math.radians(4.0))
    truth = _ellipse(12, turn0=1.0)
    revisit = [Keyframe(0.0, drift.compose(t), _scan(t)) for t in truth]
    keyframes = first + _detour(first[-1].pose, 30.0) + revisit
    for loop in LoopCloser(settings).search(keyframes, len(keyframes) - 1):
        assert math.hypot(loop.pose.x - truth[-1].x, loop.pose.y - truth[-1].y) > 1.0


def test_a_passage_that_looks_the_same_metres_further_on_is_not_a_loop() -> None:
    settings = MapperSettings.defaults(loop_closure=True, max_range_m=6.0, loop_search_xy_m=4.0)
    first = [Keyframe(0.0, p, _scan(p, CORRIDOR)) for p in _line(-15.0, 15.0)]
    detour = _detour(first[-1].pose, 150.0)
    revisit = [Keyframe(0.0, p, _scan(p, CORRIDOR)) for p in _line(-3.0, 0.0)]
    keyframes = first + detour + revisit
    closer = LoopCloser(settings)
    assert closer.search(keyframes, len(keyframes) - 1) == []
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
