"""Formations and a group goal's orders: places, who takes which, the shape error, the
orders (valid VDA 5050, starting together), and steps released only when all are there."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest

from navd.fleetctl import control
from navd.fleetctl.control import one_map
from navd.fleetctl.errors import GroupGoalError
from navd.fleetctl.formation import assign, places, shape_error, slots
from navd.fleetctl.group import GroupDrive, GroupGoal
from navd.fleetctl.view import FleetView, Vehicle, instant_action
from tests.fleet.vda5050_schemas import check


@pytest.mark.parametrize("kind", ["line", "column", "triangle"])
@pytest.mark.parametrize("count", [2, 3, 5])
def test_places_are_centred_and_neighbours_spacing_apart(kind: Any, count: int) -> None:
    offsets = slots(kind, count, 1.2)
    assert offsets.mean(axis=0) == pytest.approx([0.0, 0.0], abs=1e-12)
    gaps = np.hypot(*(offsets[:, None] - offsets[None]).transpose(2, 0, 1))
    nearest = np.where(np.eye(count, dtype=bool), np.inf, gaps).min(axis=1)
    assert nearest == pytest.approx(np.full(count, 1.2))  # everyone has a neighbour 1.2 m off


def test_a_triangle_of_three_is_equilateral_and_points_along_the_heading() -> None:
    offsets = slots("triangle", 3, 1.0)
    for a, b in itertools.combinations(offsets, 2):
        assert math.dist(a, b) == pytest.approx(1.0)
    leader = offsets[np.argmax(offsets[:, 0])]
    assert leader[1] == pytest.approx(0.0)  # the apex leads, on the centre line
    turned = places((10.0, 5.0), math.pi / 2, offsets)
    apex = turned[np.argmax(turned[:, 1])]
    assert apex[0] == pytest.approx(10.0) and turned.mean(axis=0) == pytest.approx([10.0, 5.0])


def test_each_robot_takes_the_place_that_keeps_the_driving_least() -> None:
    spots = np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]])
    robots = np.array([[0.2, 4.8], [4.9, 0.3], [0.1, -0.2]])
    assert list(assign(robots, spots)) == [2, 1, 0]


def test_the_shape_error_ignores_where_the_group_is_and_which_way_it_faces() -> None:
    offsets = slots("triangle", 3, 1.0)
    moved = places((7.0, -3.0), 2.0, offsets)
    assert shape_error(moved, offsets) == pytest.approx(0.0, abs=1e-9)
    moved[0] += [0.2, 0.0]  # one robot 20 cm off its place: the best fit shares it out
    assert 0.05 < shape_error(moved, offsets) <= 0.2 + 1e-9
    swapped = moved[[1, 0, 2]]  # two robots in each other's places: far from the shape
    assert shape_error(swapped, offsets) > 0.4


def _group() -> GroupDrive:
    robots = [("navd", "r1", 0.0, 0.0), ("navd", "r2", 0.0, 1.0), ("navd", "r3", 1.0, 0.5)]
    return GroupDrive(
        "g", robots, GroupGoal(6.0, 0.5, spacing_m=1.0, step_m=2.0), now_unix_s=1000.0
    )


def _state(group: GroupDrive, serial: str, place: int, xy: tuple[float, float]) -> dict[str, Any]:
    return {
        "orderId": f"g-{serial}",
        "lastNodeSequenceId": 2 * (place + 1),
        "agvPosition": {"x": xy[0], "y": xy[1]},
        "errors": [],
    }


def _started(group: GroupDrive) -> list[tuple[Any, dict[str, Any]]]:
    """The first orders sent, then the start time come: the start's updates."""
    group.first_orders()
    return group.start(group.start_unix_s)


def test_the_first_orders_hold_every_robot_until_the_start_releases_them_together() -> None:
    group = _group()
    orders = group.first_orders()
    assert len(orders) == 3 and group.steps == 4  # form up, then 3 steps of 2 m at most
    for member, order in orders:
        check("order", order)
        start, form_up = order["nodes"]
        assert (start["nodePosition"]["x"], start["nodePosition"]["y"]) == member.start_xy
        assert start["actions"] == []  # nothing but standard orders: no "wait" action
        assert (start["released"], form_up["released"]) == (True, False)
    assert group.start(now_unix_s=1001.9) == []  # the start time is 1002 (2 s after 1000)
    started = group.start(now_unix_s=1002.0)
    assert [m.serial for m, _ in started] == ["r1", "r2", "r3"]
    for member, order in started:
        check("order", order)
        stitch, form_up, horizon = order["nodes"]
        assert order["orderUpdateId"] == 1 and stitch["sequenceId"] == 0
        assert (stitch["nodePosition"]["x"], stitch["nodePosition"]["y"]) == member.start_xy
        assert (form_up["released"], horizon["released"]) == (True, False)
    assert group.start(now_unix_s=1003.0) == []  # once
    # the places: a triangle around the robots' mean, then along the way to the goal
    last = np.array([m.places[-1] for m in group.members])
    assert last.mean(axis=0) == pytest.approx([6.0, 0.5])
    sides = [math.dist(a, b) for a, b in itertools.combinations(last, 2)]
    assert sides == pytest.approx([1.0, 1.0, 1.0])  # the triangle, 1 m sides


def test_each_vehicles_orders_count_their_own_header_ids() -> None:
    group = _group()
    first = group.first_orders()
    assert [order["headerId"] for _, order in first] == [1, 1, 1]
    started = group.start(group.start_unix_s)
    assert [order["headerId"] for _, order in started] == [2, 2, 2]
    updates = []
    for m in group.members:
        updates += group.on_state(m.serial, _state(group, m.serial, 0, tuple(m.places[0])))
    assert [order["headerId"] for _, order in updates] == [3, 3, 3]


def test_a_step_is_released_only_when_every_robot_is_at_its_place() -> None:
    group = _group()
    group.first_orders()
    r1, r2, r3 = group.members
    # before the start, a robot that says it is at its form-up place releases nothing
    assert group.on_state("r1", _state(group, "r1", 0, tuple(r1.places[0]))) == []
    group.start(group.start_unix_s)
    assert group.on_state("r1", _state(group, "r1", 0, tuple(r1.places[0]))) == []
    assert group.on_state("r2", _state(group, "r2", 0, tuple(r2.places[0]))) == []
    assert group.on_state("r9", _state(group, "r9", 0, (0.0, 0.0))) == []  # not in the group
    updates = group.on_state("r3", _state(group, "r3", 0, tuple(r3.places[0])))
    assert [m.serial for m, _ in updates] == ["r1", "r2", "r3"]
    for _, order in updates:
        check("order", order)
        stitch, released, horizon = order["nodes"]
        assert order["orderUpdateId"] == 2 and (stitch["sequenceId"], released["sequenceId"]) == (
            2,
            4,
        )
        assert released["released"] and not horizon["released"]
    for m in group.members:  # each heard at another time, driving at 0.5 m/s along +x
        t = {"r1": 10.0, "r2": 10.4, "r3": 10.2}[m.serial]
        x, y = m.places[0] + [0.5 * (t - 11.0), 0.0]
        view = {"agvPosition": {"x": x, "y": y, "theta": 0.0}, "velocity": {"vx": 0.5}}
        group.on_position(m.serial, view, heard_s=t)
    assert group.shape_error_m(11.0) == pytest.approx(0.0, abs=1e-9)  # all carried on to t = 11
    for place in range(1, group.steps):
        for m in group.members:
            group.on_state(m.serial, _state(group, m.serial, place, tuple(m.places[place])))
    assert group.done and group.released == group.steps - 1


@pytest.mark.parametrize("kind", ["stateRequest", "startPause", "stopPause"])
def test_the_fleet_controls_instant_actions_are_valid_vda5050(kind: str) -> None:
    message = instant_action("navd", "r1", 3, kind, f"a-{kind}")
    check("instantActions", message)
    assert message["actions"][0]["actionType"] == kind
    # to a 2.0 vehicle, in 2.0: the list under 2.0's name (vda-5050-lib's vehicle reads it)
    spoken = instant_action("navd", "r1", 3, kind, f"a-{kind}", version="2.0.0")
    assert spoken["version"] == "2.0.0" and "actions" not in spoken
    assert spoken["instantActions"] == message["actions"]


def test_a_robot_ahead_of_the_slowest_waits_until_it_catches_up() -> None:
    group = _group()
    _started(group)
    for m in group.members:  # all formed up: step 1 released
        group.on_state(m.serial, _state(group, m.serial, 0, tuple(m.places[0])))
    assert group.released == 1
    r1, r2, r3 = group.members

    def at(m: Any, along: float, t: float) -> None:
        a, b = m.places[0], m.places[1]
        x, y = a + (b - a) * along / float(np.hypot(*(b - a)))
        group.on_position(m.serial, {"agvPosition": {"x": x, "y": y, "theta": 0.0}}, t)

    at(r1, 0.5, 5.0)
    at(r2, 0.3, 5.0)
    at(r3, 0.1, 5.0)
    # r1 is 0.4 m and r2 0.2 m ahead of r3: both wait
    assert [(m.serial, a) for m, a in group.corrections(5.0)] == [
        ("r1", "startPause"),
        ("r2", "startPause"),
    ]
    assert group.corrections(5.1) == []  # told once
    x, y = r1.places[0] + (r1.places[1] - r1.places[0]) * 0.5 / np.hypot(
        *(r1.places[1] - r1.places[0])
    )
    # the centre's way: 5.7 m from the robots' mean to the goal in 2 m steps, 3 of them
    assert r1.progress_report() == {
        "serial": "r1",
        "last_place": 0,
        "of": 3,
        "paused": True,
        "errors": [],
        "at_m": [round(x, 2), round(y, 2)],
    }
    at(r3, 0.28, 6.0)
    assert [(m.serial, a) for m, a in group.corrections(6.0)] == [("r2", "stopPause")]
    at(r2, 0.5, 7.0)
    at(r3, 0.5, 7.0)
    assert [(m.serial, a) for m, a in group.corrections(7.0)] == [("r1", "stopPause")]


def test_a_pause_or_resume_a_vehicle_refused_is_sent_again_until_its_state_agrees() -> None:
    group = _group()
    _started(group)
    for m in group.members:  # all formed up: step 1 released
        group.on_state(m.serial, _state(group, m.serial, 0, tuple(m.places[0])))
    r1, r2, r3 = group.members

    def at(m: Any, along: float, t: float, paused: bool) -> None:
        a, b = m.places[0], m.places[1]
        x, y = a + (b - a) * along / float(np.hypot(*(b - a)))
        group.on_position(m.serial, {"agvPosition": {"x": x, "y": y, "theta": 0.0}}, t)
        group.on_state(m.serial, _state(group, m.serial, 0, (x, y)) | {"paused": paused})

    at(r1, 0.5, 5.0, False)
    at(r2, 0.1, 5.0, False)
    at(r3, 0.1, 5.0, False)
    assert [(m.serial, a) for m, a in group.corrections(5.0)] == [("r1", "startPause")]
    at(r1, 0.5, 5.5, True)  # it paused
    at(r2, 0.45, 6.0, False)
    at(r3, 0.45, 6.0, False)
    assert [(m.serial, a) for m, a in group.corrections(6.0)] == [("r1", "stopPause")]
    # its state still says paused (it refused the stopPause, say): again after RESEND_S,
    # not before, and not once it says it drives
    at(r1, 0.5, 7.0, True)
    assert group.corrections(7.0) == []
    assert [(m.serial, a) for m, a in group.corrections(8.1)] == [("r1", "stopPause")]
    assert group.corrections(9.0) == []
    at(r1, 0.5, 10.5, False)
    assert group.corrections(10.5) == []
    # a robot paused by someone else (never by the group) is left to them
    at(r2, 0.45, 11.0, True)
    assert group.corrections(14.0) == []


def test_a_held_robot_that_reaches_its_place_is_let_go() -> None:
    group = _group()
    _started(group)
    for m in group.members:
        group.on_state(m.serial, _state(group, m.serial, 0, tuple(m.places[0])))
    r1, r2, r3 = group.members

    def at(m: Any, along: float, t: float) -> None:
        a, b = m.places[0], m.places[1]
        x, y = a + (b - a) * along / float(np.hypot(*(b - a)))
        group.on_position(m.serial, {"agvPosition": {"x": x, "y": y, "theta": 0.0}}, t)

    at(r1, 1.0, 5.0)
    at(r2, 0.2, 5.0)
    at(r3, 0.2, 5.0)
    assert [(m.serial, a) for m, a in group.corrections(5.0)] == [("r1", "startPause")]
    # the pause came late: r1 stood at its place when it took effect
    group.on_state("r1", _state(group, "r1", 1, tuple(r1.places[1])))
    assert [(m.serial, a) for m, a in group.corrections(6.0)] == [("r1", "stopPause")]
    assert not r1.paused


def test_robots_on_different_maps_or_another_than_asked_are_refused_by_serial() -> None:
    one_map({"r1": "office", "r2": "office"})
    one_map({"r1": "office"}, "office")
    one_map({})  # no robot says: nothing to compare
    with pytest.raises(GroupGoalError, match=r"r1 on 'office', r2 on 'map'.*slam\.map_name"):
        one_map({"r1": "office", "r2": "map"})
    with pytest.raises(GroupGoalError, match=r"\(--map-id 'hall'\): r1 on 'office'"):
        one_map({"r1": "office"}, "hall")


async def test_a_group_goal_checks_the_robots_maps_before_any_order(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    view = FleetView("uagv")
    for serial, map_id in (("r1", "office"), ("r2", "map")):
        state = {"agvPosition": {"x": 1.0, "y": 2.0, "theta": 0.0, "mapId": map_id}}
        view.vehicles[f"navd/{serial}"] = Vehicle("navd", serial, "ONLINE", state)

    async def heard(*_: object) -> FleetView:
        return view

    monkeypatch.setattr(control, "fleet_view", heard)
    # the broker is never reached: the port below has nobody listening
    with pytest.raises(GroupGoalError, match="not all on one map"):
        await control.drive_group("mqtt://127.0.0.1:9", GroupGoal(5.0, 5.0))
