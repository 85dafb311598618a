"""The group's way on a map: round walls, the formation where it fits, a column through a
door (in the order the robots stand, on the route), the straight line without a map, and
refusals that name the place."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from navd.cli.fleet import DEFAULT_RADIUS_M as CLI_RADIUS_M
from navd.fleetctl.errors import GroupGoalError
from navd.fleetctl.group import GroupDrive, GroupGoal
from navd.fleetctl.group_map import DEFAULT_RADIUS_M, GroupMap
from navd.fleetctl.group_route import GroupRoute, lay_out
from navd.sim import office
from navd.slam import OccupancyGrid, save_map
from tests.fleet.vda5050_schemas import check

RES_M = 0.05
ORIGIN = (-1.0, -1.0)


def _two_rooms() -> npt.NDArray[np.bool_]:
    """Walls round a 14 m x 8 m floor, split at x = 6 by a wall with a 1 m door at y 3..4."""
    grid = np.zeros((200, 320), dtype=bool)  # 10 m x 16 m from (-1, -1)

    def wall(x0: float, y0: float, x1: float, y1: float) -> None:
        c0, c1 = round((x0 - ORIGIN[0]) / RES_M), round((x1 - ORIGIN[0]) / RES_M)
        r0, r1 = round((y0 - ORIGIN[1]) / RES_M), round((y1 - ORIGIN[1]) / RES_M)
        grid[r0 : r1 + 1, c0 : c1 + 1] = True

    wall(0.0, 0.0, 14.0, 0.0)
    wall(0.0, 8.0, 14.0, 8.0)
    wall(0.0, 0.0, 0.0, 8.0)
    wall(14.0, 0.0, 14.0, 8.0)
    wall(6.0, 0.0, 6.0, 3.0)
    wall(6.0, 4.0, 6.0, 8.0)
    return grid


ROBOTS = np.array([[1.5, 2.0], [1.5, 5.0], [2.5, 3.5]])


def _way() -> tuple[GroupMap, GroupRoute]:
    walls = GroupMap.of_grid(_two_rooms(), ORIGIN, RES_M)
    way = lay_out(
        ROBOTS,
        (11.0, 4.0),
        goal_heading_rad=0.0,
        formation="triangle",
        spacing_m=1.5,
        step_m=1.0,
        group_map=walls,
    )
    return walls, way


def test_the_group_goes_through_a_door_in_a_column_and_spreads_out_after_it() -> None:
    walls, way = _way()
    shapes = list(way.shapes)
    # formed up as asked, a column in the middle, the triangle again at the goal; each change
    # of shape is made standing (the centre stays where it was)
    for k in range(1, len(shapes)):
        if shapes[k] != shapes[k - 1]:
            assert way.places_m[:, k].mean(axis=0) == pytest.approx(
                way.places_m[:, k - 1].mean(axis=0),
                abs=0.1,  # a column on a bend: about
            )
    assert shapes[0] == "triangle" and shapes[-1] == "triangle"
    first, last = shapes.index("column"), len(shapes) - 1 - shapes[::-1].index("column")
    assert set(shapes[first : last + 1]) == {"column"}
    # every place of every step is clear of the walls for a robot
    places = way.places_m.reshape(-1, 2)
    assert (walls.clearance_m(places) >= DEFAULT_RADIUS_M).all()
    # each robot crosses the wall once, on its way into or out of the column, in the door
    for robot in way.places_m:
        crossings = 0
        for k in range(1, robot.shape[0]):
            (x0, y0), (x1, y1) = robot[k - 1], robot[k]
            if (x0 - 6.0) * (x1 - 6.0) < 0:
                crossings += 1
                assert "column" in (way.shapes[k - 1], way.shapes[k])
                y = y0 + (6.0 - x0) * (y1 - y0) / (x1 - x0)
                assert 3.0 + 0.2 < y < 4.0 - 0.2
        assert crossings == 1
    # at the goal: the triangle, centred on it, facing east
    end = way.places_m[:, -1]
    assert end.mean(axis=0) == pytest.approx([11.0, 4.0], abs=1e-6)
    gaps = [np.hypot(*(end[i] - end[j])) for i, j in ((0, 1), (0, 2), (1, 2))]
    assert gaps == pytest.approx([1.5, 1.5, 1.5])
    assert way.headings_rad[:, -1] == pytest.approx([0.0, 0.0, 0.0])


def test_in_a_column_the_robots_keep_their_order_along_the_route() -> None:
    _, way = _way()
    columns = [k for k, shape in enumerate(way.shapes) if shape == "column"]
    ranks = {tuple(np.argsort(way.stations_m[:, k])) for k in columns}
    assert len(ranks) == 1  # nobody overtakes inside the column
    spacing = np.diff(np.sort(way.stations_m[:, columns[0]]))
    assert spacing == pytest.approx([1.5, 1.5])  # spacing_m of route apart
    # from a column to a column: half the spacing at a time, so the next robot's place is
    # never where the one ahead stands
    for k in columns[1:]:
        if k - 1 in columns:
            step = np.diff(way.stations_m[:, k - 1 : k + 1])
            assert step.max() <= 0.75 + 1e-9
            assert step.min() > 0.0  # and always on, never back


def test_between_two_column_places_a_robot_is_expected_on_the_route_not_on_the_chord() -> None:
    _, way = _way()
    k = next(k for k in range(1, len(way.shapes)) if way.shapes[k - 1] == way.shapes[k] == "column")
    assert way.target_m(k, 0.0) == pytest.approx(way.places_m[:, k - 1])
    assert way.target_m(k, 1.0) == pytest.approx(way.places_m[:, k])
    halfway = way.target_m(k, 0.5)
    route = way.route_m
    for point in halfway:
        # distance to the route polyline: nil
        a, b = route[:-1], route[1:]
        t = np.clip(((point - a) * (b - a)).sum(1) / ((b - a) ** 2).sum(1).clip(1e-12), 0, 1)
        assert np.hypot(*(a + t[:, None] * (b - a) - point).T).min() < 1e-6


def test_without_a_map_the_way_is_straight_and_the_formation_kept() -> None:
    way = lay_out(
        ROBOTS, (11.0, 4.0), goal_heading_rad=None, formation="triangle", spacing_m=1.5,
        step_m=1.0,
    )  # fmt: skip
    assert set(way.shapes) == {"triangle"}
    centres = way.places_m.mean(axis=0)
    start = ROBOTS.mean(axis=0)
    direction = np.array([11.0, 4.0]) - start
    cross = direction[0] * (centres[:, 1] - start[1]) - direction[1] * (centres[:, 0] - start[0])
    assert cross == pytest.approx(np.zeros(centres.shape[0]), abs=1e-9)  # on the line


def test_a_goal_in_a_wall_or_too_tight_for_the_group_is_refused_by_place() -> None:
    walls = GroupMap.of_grid(_two_rooms(), ORIGIN, RES_M)
    kwargs = {"goal_heading_rad": None, "formation": "triangle", "spacing_m": 1.5, "step_m": 1.0}
    with pytest.raises(GroupGoalError, match=r"group.s centre: goal \(6.00, 1.00\) m is occupied"):
        lay_out(ROBOTS, (6.0, 1.0), group_map=walls, **kwargs)  # type: ignore[arg-type]
    # the group's centre cannot stand at the goal 0.6 m from a wall, not even in a column
    # (a column 3 m long, along the route; not moved back: the goal is the centre's)
    tight = _two_rooms()
    tight[:, round((7.2 - ORIGIN[0]) / RES_M)] = True
    walls = GroupMap.of_grid(tight, ORIGIN, RES_M)
    with pytest.raises(GroupGoalError, match=r"does not fit around \(6\.60, 3\.50\) m"):
        lay_out(ROBOTS, (6.6, 3.5), group_map=walls, **kwargs)  # type: ignore[arg-type]


def test_a_saved_map_gives_the_walls_of_its_grid(tmp_path: Path) -> None:
    walls = _two_rooms()
    logodds = np.where(walls, 4.0, -4.0).astype(np.float32)
    saved = save_map(OccupancyGrid.from_array(logodds, *ORIGIN, RES_M), tmp_path, "rooms")
    loaded = GroupMap.load(saved)
    built = GroupMap.of_grid(walls, ORIGIN, RES_M)
    probe = np.array([[1.0, 1.0], [6.0, 3.5], [10.0, 7.5], [6.0, 1.0]])
    assert loaded.clearance_m(probe) == pytest.approx(built.clearance_m(probe))
    assert CLI_RADIUS_M == DEFAULT_RADIUS_M  # `navd fleet goal --radius` defaults to the same


def test_the_shape_error_follows_the_way_through_a_change_of_shape() -> None:
    walls = GroupMap.of_grid(_two_rooms(), ORIGIN, RES_M)
    robots = [("navd", f"r{i}", float(x), float(y)) for i, (x, y) in enumerate(ROBOTS)]
    goal = GroupGoal(11.0, 4.0, heading_rad=0.0, spacing_m=1.5, step_m=1.0)
    group = GroupDrive("g", robots, goal, 0.0, group_map=walls)
    k = group.way.shapes.index("column")  # the step from the triangle into the column
    group.released = k
    for m in group.members:
        m.reached = k - 1
    for fraction in (0.25, 0.5, 0.75):
        targets = group.way.target_m(k, fraction)
        for m, (x, y) in zip(group.members, targets, strict=True):
            group.on_position(m.serial, {"agvPosition": {"x": x, "y": y}}, heard_s=5.0)
        assert group.shape_error_m(5.0) == pytest.approx(0.0, abs=0.02)
    # the robots still standing in the triangle when the group should be halfway: an error
    for m in group.members:
        x, y = m.places[k - 1]
        group.on_position(m.serial, {"agvPosition": {"x": x, "y": y}}, heard_s=6.0)
    group.members[0].position = (6.0, *group.way.target_m(k, 0.5)[0], 0.0, 0.0)
    assert group.shape_error_m(6.0) > 0.1


def test_a_robot_standing_on_a_slower_ones_place_is_never_held() -> None:
    robots = [("navd", "a", 0.0, 0.0), ("navd", "b", 0.0, 1.5), ("navd", "c", 1.3, 0.75)]
    group = GroupDrive("g", robots, GroupGoal(8.0, 0.75, spacing_m=1.5, step_m=2.0), 0.0)
    group.released = 1
    for m in group.members:
        m.reached = 0
        x, y = m.places[0]
        group.on_position(m.serial, {"agvPosition": {"x": x, "y": y}}, heard_s=1.0)
    a, b = (m for m in group.members if m.serial in ("a", "b"))
    # a has driven most of its step, swerving onto b's place, which b has not left for
    x, y = b.places[1] + [0.0, 0.2 * np.sign(a.places[1, 1] - b.places[1, 1])]
    group.on_position(a.serial, {"agvPosition": {"x": x, "y": y}}, heard_s=1.0)
    assert a.serial not in {m.serial for m, _ in group.corrections(1.0)}  # it goes on
    a.paused = True  # held before it came to stand there: let go
    assert [(m.serial, act) for m, act in group.corrections(1.1)] == [(a.serial, "stopPause")]
    # back in its own lane, as far along: ahead of the others, and nobody's way: it waits
    x, y = a.places[1]
    group.on_position(a.serial, {"agvPosition": {"x": x - 0.3, "y": y}}, heard_s=2.0)
    assert [(m.serial, act) for m, act in group.corrections(2.0)] == [(a.serial, "startPause")]


def test_across_the_office_the_column_never_steps_back_and_goes_through_both_doors() -> None:
    world = office()
    walls = GroupMap.of_grid(world.grid, (world.origin_x_m, world.origin_y_m), world.resolution_m)
    robots = np.array([(0.0, 0.0), (0.0, 1.6), (1.2, 0.0)])
    way = lay_out(
        robots, (9.4, 1.5), goal_heading_rad=0.0, formation="triangle", spacing_m=1.5,
        step_m=1.5, group_map=walls,
    )  # fmt: skip
    # the lower-left room's door is too narrow for the triangle: it sets off in a column
    # (laid on along the route from the room's corner), and spreads out at the goal
    assert way.shapes[0] == "column" and way.shapes[-1] == "triangle"
    columns = [k for k, shape in enumerate(way.shapes) if shape == "column"]
    assert np.diff(way.stations_m[:, columns], axis=1).min() > 0.0
    assert (walls.clearance_m(way.places_m.reshape(-1, 2)) >= DEFAULT_RADIUS_M).all()
    # each robot leaves the room through its door (x 3..4 at y 2.5)
    for robot in way.places_m:
        ys = robot[:, 1]
        k = int(np.flatnonzero((ys[:-1] < 2.5) & (ys[1:] >= 2.5))[0])
        (x0, y0), (x1, y1) = robot[k], robot[k + 1]
        assert 3.0 < x0 + (2.5 - y0) * (x1 - x0) / (y1 - y0) < 4.0


def test_a_column_place_has_no_heading_to_turn_to_but_a_formation_place_and_the_goal_do() -> None:
    walls = GroupMap.of_grid(_two_rooms(), ORIGIN, RES_M)
    robots = [("navd", f"r{i}", float(x), float(y)) for i, (x, y) in enumerate(ROBOTS)]
    goal = GroupGoal(11.0, 4.0, heading_rad=0.0, spacing_m=1.5, step_m=1.5)
    group = GroupDrive("g", robots, goal, 0.0, group_map=walls)
    orders = {m.serial: [o] for m, o in group.first_orders()}
    for member, order in group.start(group.start_unix_s):
        orders[member.serial].append(order)
    for k in range(group.steps - 1):  # everyone reaches each place in turn
        for m in group.members:
            state = {
                "orderId": f"g-{m.serial}",
                "lastNodeSequenceId": 2 * (k + 1),
                "agvPosition": {"x": float(m.places[k, 0]), "y": float(m.places[k, 1])},
                "errors": [],
            }
            for member, order in group.on_state(m.serial, state):
                orders[member.serial].append(order)
    for m in group.members:
        for order in orders[m.serial]:
            check("order", order)  # valid VDA 5050, with and without headings
        nodes = {n["sequenceId"]: n for o in orders[m.serial] for n in o["nodes"]}
        for k, shape in enumerate(group.way.shapes):
            position = nodes[2 * (k + 1)]["nodePosition"]
            assert ("theta" in position) == (shape == "triangle" or k == group.steps - 1)
        assert nodes[2 * group.steps]["nodePosition"]["theta"] == pytest.approx(0.0)


def test_a_goal_just_past_a_door_is_reached_in_a_column_that_spreads_out_there() -> None:
    # a line 3 m wide fits at the goal, 0.75 m past the door, and fits just before the door:
    # it must not spread out before the door and go through it abreast
    walls = GroupMap.of_grid(_two_rooms(), ORIGIN, RES_M)
    robots = np.array([[3.0, 3.5], [4.5, 3.5], [3.75, 5.0]])
    way = lay_out(
        robots, (8.0, 3.5), goal_heading_rad=0.0, formation="line", spacing_m=1.5, step_m=1.5,
        group_map=walls,
    )  # fmt: skip
    assert way.shapes[-1] == "line"
    for robot in way.places_m:  # each robot crosses the wall x = 6 in the door, in a column
        for k in range(1, robot.shape[0]):
            (x0, y0), (x1, y1) = robot[k - 1], robot[k]
            if (x0 - 6.0) * (x1 - 6.0) < 0:
                assert way.shapes[k] == "column" == way.shapes[k - 1]
                assert 3.2 < y0 + (6.0 - x0) * (y1 - y0) / (x1 - x0) < 3.8


@pytest.mark.parametrize("with_map", [False, True])
def test_a_goal_where_the_group_is_turns_it_there_in_place(with_map: bool) -> None:
    walls = GroupMap.of_grid(_two_rooms(), ORIGIN, RES_M) if with_map else None
    robots = np.array([[2.0, 3.0], [2.0, 5.0], [3.5, 4.0]])
    centre = robots.mean(axis=0)
    way = lay_out(
        robots, (float(centre[0]), float(centre[1])), goal_heading_rad=math.pi / 2,
        formation="column", spacing_m=1.5, step_m=1.5, group_map=walls,
    )  # fmt: skip
    end = way.places_m[:, -1]
    assert end.mean(axis=0) == pytest.approx(centre, abs=1e-3)
    # a column 1.5 m apart along the goal's heading (north), not three robots on one spot
    assert sorted(end[:, 1] - centre[1]) == pytest.approx([-1.5, 0.0, 1.5], abs=1e-3)
    assert end[:, 0] == pytest.approx(np.full(3, centre[0]), abs=1e-3)
    assert way.headings_rad[:, -1] == pytest.approx(np.full(3, math.pi / 2))


def test_a_column_at_the_goal_lies_along_the_goals_heading() -> None:
    walls = GroupMap.of_grid(_two_rooms(), ORIGIN, RES_M)
    way = lay_out(
        ROBOTS, (10.0, 4.0), goal_heading_rad=math.pi / 2, formation="column", spacing_m=1.5,
        step_m=1.5, group_map=walls,
    )  # fmt: skip
    end = way.places_m[:, -1]
    assert end[:, 0] == pytest.approx(np.full(3, 10.0), abs=1e-6)  # arrived going east,
    assert sorted(end[:, 1]) == pytest.approx([2.5, 4.0, 5.5], abs=1e-6)  # lined up north
