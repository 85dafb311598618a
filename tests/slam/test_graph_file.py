"""Maps that go on growing: a map saved with its pose graph reloads bit for bit, and a later
run maps on from it, closing loops onto the first run's keyframes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navd.geometry import Pose2
from navd.slam.errors import MapFileError
from navd.slam.graph_file import MapGraph
from navd.slam.map_io import load_map, load_map_state, save_map
from navd.slam.mapper import ScanMapper
from navd.slam.settings import MapperSettings
from tests.slam.test_lost_search import room_scan


def ellipse(i: int, per_lap: int = 80) -> Pose2:
    """The i-th pose of a drive round the bench room (80 a lap, facing along the way)."""
    angle = 2 * math.pi * i / per_lap
    return Pose2(4.0 * math.cos(angle) - 0.5, 2.2 * math.sin(angle) - 0.5, angle + math.pi / 2)


def drive(mapper: ScanMapper, steps: range) -> None:
    """Odometry a little long (3 % from where the drive starts), so the graph has
    something to correct."""
    start = ellipse(steps[0])
    for i in steps:
        truth = ellipse(i)
        odom = Pose2(
            truth.x + 0.03 * (truth.x - start.x), truth.y + 0.03 * (truth.y - start.y), truth.yaw
        )
        mapper.add(0.1 * i, room_scan(truth), odom)


def assert_same_graph(a: MapGraph, b: MapGraph) -> None:
    assert len(a.keyframes) == len(b.keyframes) and len(a.edges) == len(b.edges)
    for x, y in zip(a.keyframes, b.keyframes, strict=True):
        assert (x.stamp, tuple(x.pose), x.mapped) == (y.stamp, tuple(y.pose), y.mapped)
        assert (x.scan is None) == (y.scan is None)
        if x.scan is not None and y.scan is not None:
            np.testing.assert_array_equal(x.scan.hits, y.scan.hits)
            np.testing.assert_array_equal(x.scan.misses, y.scan.misses)
            assert x.scan.view == y.scan.view
    assert a.edges == b.edges
    assert (a.base is None) == (b.base is None)
    if a.base is not None and b.base is not None:
        np.testing.assert_array_equal(a.base.to_array(), b.base.to_array())


def test_a_map_saved_with_its_graph_reloads_bit_exact(tmp_path: Path) -> None:
    mapper = ScanMapper(MapperSettings.defaults())
    drive(mapper, range(100))  # more than a lap: loops closed, the graph re-solved
    assert mapper.counts.keyframes > 40 and any(e.robust for e in mapper.edges)
    graph = mapper.graph()
    path = save_map(mapper.grid, tmp_path, "room", graph=graph)
    saved = load_map_state(path)
    assert saved.graph is not None
    np.testing.assert_array_equal(saved.grid.to_array(), mapper.grid.to_array())
    assert (saved.grid.origin_x, saved.grid.origin_y) == (
        mapper.grid.origin_x,
        mapper.grid.origin_y,
    )
    assert_same_graph(saved.graph, graph)
    # Saved again from the reloaded state: the same again (nothing drifts through a save).
    again = load_map_state(save_map(saved.grid, tmp_path / "again", "room", graph=saved.graph))
    assert again.graph is not None
    assert_same_graph(again.graph, graph)
    # ... and a rebuild from the reloaded graph draws the map it was saved with.
    mapper.rebuild_map()
    continued = ScanMapper(MapperSettings.defaults())
    continued.load(saved.grid, saved.graph)
    continued.rebuild_map()
    np.testing.assert_array_equal(continued.grid.to_array(), mapper.grid.to_array())


def test_the_map_a_graph_was_drawn_over_is_kept_with_it(tmp_path: Path) -> None:
    first = ScanMapper(MapperSettings.defaults(loop_closure=False))
    drive(first, range(20))
    before = first.grid.to_array()
    second = ScanMapper(MapperSettings.defaults())
    second.load(first.grid)  # a map without a graph: it is the base of what comes next
    second.set_pose(ellipse(20))
    second.forget_odometry()
    drive(second, range(20, 50))
    path = save_map(second.grid, tmp_path, "room", graph=second.graph())
    saved = load_map_state(path)
    assert saved.graph is not None and saved.graph.base is not None
    np.testing.assert_array_equal(saved.graph.base.to_array(), before)
    assert_same_graph(saved.graph, second.graph())
    # ... also from a file written before the grid was tiled (the base dense), and a base
    # with a part missing is refused by name
    state = next(tmp_path.glob("room.*.npz"))
    with np.load(state) as data:
        arrays = {name: data[name] for name in data.files}
    tiled = {name: arrays.pop(name) for name in list(arrays) if name.startswith("graph_base_")}
    for name in ("origin", "resolution"):
        arrays[f"graph_base_{name}"] = tiled[f"graph_base_{name}"]
    with state.open("wb") as f:
        np.savez(f, **arrays, graph_base_logodds=before)
    saved = load_map_state(path)
    assert saved.graph is not None and saved.graph.base is not None
    np.testing.assert_array_equal(saved.graph.base.to_array(), before)
    missing = {name: a for name, a in {**arrays, **tiled}.items() if name != "graph_base_origin"}
    with state.open("wb") as f:
        np.savez(f, **missing)
    with pytest.raises(MapFileError, match="base map without its 'graph_base_origin'"):
        load_map_state(path)


def test_a_second_run_maps_on_and_closes_loops_onto_the_first(tmp_path: Path) -> None:
    first = ScanMapper(MapperSettings.defaults())
    drive(first, range(60))  # three quarters of a lap
    path = save_map(first.grid, tmp_path, "room", graph=first.graph())
    saved = load_map_state(path)
    assert saved.graph is not None
    old = len(saved.graph.keyframes)
    # The next day: started on the map, found at the first scan, driven on round the room
    # and past where the first run began.
    second = ScanMapper(MapperSettings.defaults())
    second.load(saved.grid, saved.graph)
    second.set_pose(ellipse(60))
    drive(second, range(60, 110))
    new_edges = second.edges[len(saved.graph.edges) :]
    # The first new keyframe is tied to the nearest old one (the robot was found there),
    # not to the last one of the first run by a step it never drove.
    link = new_edges[0]
    assert link.j == old and link.robust
    nearest = min(
        range(old), key=lambda k: math.dist(saved.graph.keyframes[k].pose[:2], ellipse(60)[:2])
    )
    assert link.i == nearest
    loops = [e for e in new_edges[1:] if e.robust and e.i < old <= e.j]
    assert len(loops) >= 3  # the second run's keyframes found the first run's
    # The map of both runs: the last pose is where the robot is.
    assert second.pose is not None
    truth = ellipse(109)
    assert math.hypot(second.pose.x - truth.x, second.pose.y - truth.y) < 0.05


def test_a_graph_saved_with_loop_closure_off_keeps_its_map_under_a_rebuild(tmp_path: Path) -> None:
    # Its keyframes kept no scans: nothing to redraw. A rebuild (after a loop closure of the
    # new run) must keep the saved map, not draw an empty one from scanless keyframes.
    first = ScanMapper(MapperSettings.defaults(loop_closure=False))
    drive(first, range(40))
    saved = load_map_state(save_map(first.grid, tmp_path, "room", graph=first.graph()))
    assert saved.graph is not None and saved.graph.keyframes[0].scan is None
    second = ScanMapper(MapperSettings.defaults())
    second.load(saved.grid, saved.graph)
    second.rebuild_map()
    np.testing.assert_array_equal(second.grid.to_array(), first.grid.to_array())


def test_a_map_saved_without_a_graph_loads_as_before(tmp_path: Path) -> None:
    mapper = ScanMapper(MapperSettings.defaults())
    drive(mapper, range(10))
    path = save_map(mapper.grid, tmp_path, "room")
    saved = load_map_state(path)
    assert saved.graph is None
    np.testing.assert_array_equal(load_map(path).to_array(), mapper.grid.to_array())


def test_a_graph_whose_arrays_disagree_is_refused_by_name(tmp_path: Path) -> None:
    mapper = ScanMapper(MapperSettings.defaults())
    drive(mapper, range(30))
    path = save_map(mapper.grid, tmp_path, "room", graph=mapper.graph())
    state = next(tmp_path.glob("room.*.npz"))
    with np.load(state) as data:
        arrays = {name: data[name] for name in data.files}
    for name, broken, says in (
        ("graph_edge_ij", arrays["graph_edge_ij"] + 1000, "an edge to a keyframe it does not"),
        ("graph_hit_end", arrays["graph_hit_end"][:-1], "scan offsets that disagree"),
        ("graph_hits", arrays["graph_hits"][:-5], "points its offsets do not account for"),
        ("graph_pose", arrays["graph_pose"][:, :2], "not N x 3"),
        ("graph_hits", arrays["graph_hits"].ravel(), "not N x 2"),
        ("graph_hit_end", arrays["graph_hit_end"][::-1], "not increasing"),
        (
            "graph_hits",
            np.where(
                np.arange(len(arrays["graph_hits"]))[:, None] == 7, np.nan, arrays["graph_hits"]
            ),
            "hits that are not finite",
        ),
        (
            "graph_pose",
            np.where(
                np.arange(len(arrays["graph_pose"]))[:, None] == 3, np.inf, arrays["graph_pose"]
            ),
            "poses that are not finite",
        ),
    ):
        with state.open("wb") as f:
            np.savez(f, **{**arrays, name: broken})
        with pytest.raises(MapFileError, match=says) as refused:
            load_map_state(path)
        assert state.name in str(refused.value)  # which file
        assert load_map(path).to_array().size  # the grid alone still loads
