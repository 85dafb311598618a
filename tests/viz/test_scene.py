"""navd's messages as Foxglove messages, decoded back with the schemas Foxglove publishes."""

from __future__ import annotations

import json
import math
import pathlib
from typing import Any

import numpy as np
import pytest

from navd.geometry import Footprint, LidarMount, Pose2
from navd.lifecycle.messages import Goal, LaserScan, MapUpdate, Path, PoseEstimate
from navd.viz import scene
from navd.viz.layout import lichtblick_layout, live_layout
from tests.viz.foxglove_client import protobuf_class


def decoded(message: Any) -> Any:
    """A Foxglove SDK message through its own protobuf schema, as a reader gets it."""
    schema = type(message).get_schema()
    assert schema.encoding == "protobuf"
    return protobuf_class(schema.name, schema.data).FromString(message.encode())


def yaw_of(q: Any) -> float:
    assert q.x == pytest.approx(0.0) and q.y == pytest.approx(0.0)
    return 2.0 * math.atan2(q.z, q.w)


def test_the_map_keeps_its_cells_origin_and_unknowns() -> None:
    occupancy = np.array([[-1, 0, 100, 50], [0, 0, -1, 100], [7, 8, 9, 10]], dtype=np.int8)
    update = MapUpdate(
        stamp=12.5,
        received=12.5,
        revision=3,
        resolution_m=0.05,
        origin_x_m=-2.0,
        origin_y_m=1.5,
        occupancy=occupancy,
    )
    grid = decoded(scene.occupancy_grid(update, offset_s=1000.0))
    assert grid.frame_id == "map"
    assert (grid.timestamp.seconds, grid.timestamp.nanos) == (1012, 500_000_000)
    assert grid.column_count == 4 and grid.row_stride == 4 and grid.cell_stride == 1
    assert (grid.cell_size.x, grid.cell_size.y) == (0.05, 0.05)
    assert (grid.pose.position.x, grid.pose.position.y) == (-2.0, 1.5)
    assert [f.name for f in grid.fields] == ["occupancy"]
    cells = np.frombuffer(grid.data, dtype=np.int8).reshape(3, 4)
    np.testing.assert_array_equal(cells, occupancy)  # row 0 is the lowest y, as in the map


def test_a_scan_hides_rays_without_a_trusted_return_and_keeps_its_angles() -> None:
    ranges = np.array([0.05, 1.0, np.inf, 2.5, 31.0], dtype=np.float32)
    scan = LaserScan(
        stamp=3.0,
        received=3.0,
        device_id="lidar0",
        angle_min=1.0,
        angle_increment=-0.25,  # a clockwise lidar
        ranges=ranges,
        range_min=0.1,
        range_max=30.0,
    )
    mount = LidarMount(Pose2(0.2, -0.1, 0.5), min_range_m=0.0)
    shown = decoded(scene.laser_scan(scan, mount))
    assert shown.frame_id == "base_link"
    assert (shown.pose.position.x, shown.pose.position.y) == pytest.approx((0.2, -0.1))
    assert shown.start_angle == pytest.approx(1.0)
    assert shown.end_angle == pytest.approx(0.0)
    got = np.array(shown.ranges)
    assert got.size == 5
    assert np.isnan(got[[0, 2, 4]]).all()  # below range_min, no return, beyond range_max
    assert got[1] == pytest.approx(1.0) and got[3] == pytest.approx(2.5)


def pose_estimate() -> PoseEstimate:
    cov = np.array([[0.04, 0.01, 0.002], [0.01, 0.09, 0.003], [0.002, 0.003, 0.0025]])
    return PoseEstimate(
        stamp=7.0,
        received=7.0,
        x_m=1.5,
        y_m=-0.5,
        yaw_rad=2.0,
        covariance=cov,
        linear_mps=0.3,
        angular_radps=-0.2,
    )


def test_the_frame_tree_runs_map_odom_base_link_laser() -> None:
    tree = decoded(scene.frame_tree(pose_estimate(), Pose2(0.2, -0.05, math.pi)))
    links = [(t.parent_frame_id, t.child_frame_id) for t in tree.transforms]
    assert links == [("map", "odom"), ("odom", "base_link"), ("base_link", "laser")]
    identity, robot, laser = tree.transforms
    assert (identity.translation.x, identity.translation.y) == (0.0, 0.0)
    assert yaw_of(identity.rotation) == pytest.approx(0.0)
    assert (robot.translation.x, robot.translation.y) == (1.5, -0.5)
    assert yaw_of(robot.rotation) == pytest.approx(2.0)
    assert (laser.translation.x, laser.translation.y) == (0.2, -0.05)
    assert abs(yaw_of(laser.rotation)) == pytest.approx(math.pi)


def test_the_pose_carries_its_covariance_on_x_y_and_yaw() -> None:
    estimate = pose_estimate()
    odom = decoded(scene.odometry(estimate))
    assert (odom.frame_id, odom.body_frame_id) == ("map", "base_link")
    assert yaw_of(odom.pose.orientation) == pytest.approx(2.0)
    cov = np.array(odom.pose_covariance).reshape(6, 6)
    index = [0, 1, 5]
    np.testing.assert_allclose(cov[np.ix_(index, index)], estimate.covariance)
    untouched = np.ones((6, 6), dtype=bool)
    untouched[np.ix_(index, index)] = False
    assert not cov[untouched].any()
    assert odom.linear_velocity.x == pytest.approx(0.3)
    assert odom.angular_velocity.z == pytest.approx(-0.2)


def test_route_goal_and_zones_are_drawn_in_the_map_frame() -> None:
    points = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 0.5]])
    route = decoded(scene.route_scene(Path(stamp=1.0, received=1.0, goal_id="g", points_m=points)))
    (entity,) = route.entities
    assert (entity.frame_id, entity.id) == ("map", "route")
    assert [(p.x, p.y) for p in entity.lines[0].points] == [(0.0, 0.0), (1.0, 0.5), (2.0, 0.5)]
    goal = decoded(scene.goal_scene(Goal(stamp=1.0, received=1.0, goal_id="g", x_m=3.0, y_m=4.0)))
    arrow = goal.entities[0].arrows[0]
    assert (arrow.pose.position.x, arrow.pose.position.y) == (3.0, 4.0)
    zones = (((0.0, 0.0), (1.0, 0.0), (1.0, 1.0)), ((5.0, 5.0), (6.0, 5.0), (6.0, 7.0), (5.0, 7.0)))
    drawn = decoded(scene.keep_out_scene(zones, 2.0)).entities[0]
    assert drawn.frame_id == "map"
    assert [len(line.points) for line in drawn.lines] == [3, 4]
    assert (drawn.lines[1].points[2].x, drawn.lines[1].points[2].y) == (6.0, 7.0)


@pytest.mark.parametrize(
    ("footprint", "corners"),
    [
        (Footprint.rectangle(0.4, 0.3), {(0.2, 0.15), (-0.2, 0.15), (-0.2, -0.15), (0.2, -0.15)}),
        (Footprint.circle(0.25), None),
    ],
    ids=["rectangle", "circle"],
)
def test_the_footprint_moves_with_base_link(
    footprint: Footprint, corners: set[tuple[float, float]] | None
) -> None:
    entity = decoded(scene.footprint_scene(footprint, 0.0)).entities[0]
    assert entity.frame_id == "base_link" and entity.frame_locked
    points = [(round(p.x, 6), round(p.y, 6)) for p in entity.lines[0].points]
    if corners is not None:
        assert set(points) == corners
    else:
        radii = [math.hypot(x, y) for x, y in points]
        assert len(points) == scene.CIRCLE_SIDES
        assert radii == pytest.approx([0.25] * len(points), abs=1e-6)


def test_the_layout_in_the_repository_is_the_one_navd_builds() -> None:
    shipped = pathlib.Path(__file__).parents[2] / "config" / "foxglove" / "navd-live.json"
    assert shipped.read_text(encoding="utf-8") == live_layout().to_json() + "\n", (
        "config/foxglove/navd-live.json is out of date: run "
        "`navd viz layout --out config/foxglove/navd-live.json`"
    )


def test_the_lichtblick_layout_in_the_repository_is_the_one_navd_builds() -> None:
    shipped = pathlib.Path(__file__).parents[2] / "config" / "lichtblick" / "navd-live.json"
    assert json.loads(shipped.read_text(encoding="utf-8")) == lichtblick_layout(), (
        "config/lichtblick/navd-live.json is out of date: run "
        "`navd viz layout --for lichtblick --out config/lichtblick/navd-live.json`"
    )


def _leaves(node: Any) -> list[str]:
    if isinstance(node, str):
        return [node]
    assert set(node) == {"first", "second", "direction", "splitPercentage"}
    assert node["direction"] in ("row", "column") and 0 < node["splitPercentage"] < 100
    return _leaves(node["first"]) + _leaves(node["second"])


def test_the_lichtblick_layout_has_the_same_panels_in_lichtblicks_own_format() -> None:
    layout = lichtblick_layout()
    assert set(layout) == {"configById", "globalVariables", "userNodes", "playbackConfig", "layout"}
    leaves = _leaves(layout["layout"])
    assert sorted(leaves) == sorted(layout["configById"])  # every panel placed once
    # the panel types Lichtblick registers: 3D, RawMessages, RosOut (its log panel)
    assert [leaf.split("!")[0] for leaf in leaves] == ["3D", "RawMessages", "RawMessages", "RosOut"]
    configs = [layout["configById"][leaf] for leaf in leaves]
    view, status, goal, log = configs
    assert view["followTf"] == "base_link" and view["fixedFrame"] == "map"
    assert "/pose" not in view["topics"] and view["topics"]["/pose/in_frame"]["visible"]
    assert (status["topicPath"], goal["topicPath"]) == ("/status", "/goal_status")
    assert log["topicToRender"] == "/log" and log["minLogLevel"] == 1
    # the 3D view takes three quarters of the width, as in Foxglove's layout
    assert (layout["layout"]["direction"], layout["layout"]["splitPercentage"]) == ("row", 75.0)
