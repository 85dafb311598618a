"""The VDA 5050 vehicle's order logic, input by input: orders driven node by node, the
horizon waiting for updates stitched at the decision point, node actions, instant actions,
and every refusal the specification names; each state it reports validates against the
2.1.0 schema."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
from typing import Any

import pytest

from navd.config import NavdConfig
from navd.fleet import reports
from navd.fleet.settings import FleetSettings
from navd.fleet.vehicle import CANCEL_STOP_S, RETRY_S, Vehicle
from navd.geometry import Pose2
from navd.lifecycle.messages import CancelGoal, Goal, GoalStatus, InitialPose, Message
from tests.fleet.vda5050_schemas import check

HERE = Pose2(0.0, 0.0, 0.0)
MAKER, SERIAL = "navd", "robot-1"


def _head(n: int = 0) -> dict[str, Any]:
    return {
        "headerId": n,
        "timestamp": "2026-12-02T08:00:00.000Z",
        "version": "2.1.0",
        "manufacturer": MAKER,
        "serialNumber": SERIAL,
    }


def node(
    node_id: str, seq: int, x: float, y: float, *, released: bool = True, **extra: Any
) -> dict[str, Any]:
    position = {"x": x, "y": y, "mapId": "map", **extra.pop("position", {})}
    return {
        "nodeId": node_id,
        "sequenceId": seq,
        "released": released,
        "nodePosition": position,
        "actions": [],
        **extra,
    }


def edge(a: dict[str, Any], b: dict[str, Any], **extra: Any) -> dict[str, Any]:
    return {
        "edgeId": f"{a['nodeId']}-{b['nodeId']}",
        "sequenceId": a["sequenceId"] + 1,
        "released": a["released"] and b["released"],
        "startNodeId": a["nodeId"],
        "endNodeId": b["nodeId"],
        "actions": [],
        **extra,
    }


def order(
    nodes: list[dict[str, Any]],
    *,
    order_id: str = "o1",
    update: int = 0,
    edges: list[dict[str, Any]] | None = None,
) -> dict[str, Any]:
    if edges is None:
        edges = [edge(a, b) for a, b in itertools.pairwise(nodes)]
    message = {
        **_head(),
        "orderId": order_id,
        "orderUpdateId": update,
        "nodes": nodes,
        "edges": edges,
    }
    check("order", message)  # every example order the tests send is a valid one
    return message


def instant(*actions: dict[str, Any]) -> bytes:
    message = {**_head(), "actions": list(actions)}
    check("instantActions", message)
    return json.dumps(message).encode()


def action(kind: str, action_id: str, blocking: str = "NONE", **params: Any) -> dict[str, Any]:
    return {
        "actionType": kind,
        "actionId": action_id,
        "blockingType": blocking,
        "actionParameters": [{"key": k, "value": v} for k, v in params.items()],
    }


def _vehicle() -> tuple[Vehicle, list[str]]:
    asked: list[str] = []
    return Vehicle(MAKER, SERIAL, asked.append), asked


def send(vehicle: Vehicle, message: dict[str, Any], pose: Pose2 = HERE) -> list[Message]:
    return vehicle.on_order(json.dumps(message).encode(), 0.0, pose)


def goals(out: list[Message]) -> list[Goal]:
    return [m for m in out if isinstance(m, Goal)]


def reach(vehicle: Vehicle, goal: Goal, now: float = 1.0) -> list[Message]:
    status = GoalStatus(stamp=now, received=now, goal_id=goal.goal_id, state="reached")
    return vehicle.on_goal_status(status, now)


def state_of(vehicle: Vehicle) -> dict[str, Any]:
    robot = reports.Robot((1.0, 2.0, 0.5), 0.05, (0.3, 0.1), (), False, "map", driving=True)
    message = reports.state(reports.header(7, 1.8e9, MAKER, SERIAL), vehicle, robot)
    check("state", message)
    return message


def errors_of(vehicle: Vehicle) -> dict[str, dict[str, Any]]:
    return {e["errorType"]: e for e in state_of(vehicle)["errors"]}


def test_an_order_is_driven_node_by_node_and_reported_as_it_goes() -> None:
    vehicle, _ = _vehicle()
    n0, n1, n2 = (
        node("a", 0, 0.2, 0.0),
        node("b", 2, 3.0, 0.0, position={"theta": 1.5}),
        node("c", 4, 3.0, 2.0),
    )
    edges = [edge(n0, n1, maxSpeed=0.3), edge(n1, n2)]
    (first,) = goals(send(vehicle, order([n0, n1, n2], edges=edges)))
    # the first node is where the robot stands: traversed at once; the goal is the next
    state = state_of(vehicle)
    assert (state["lastNodeId"], state["lastNodeSequenceId"]) == ("a", 0)
    assert [n["nodeId"] for n in state["nodeStates"]] == ["b", "c"]
    assert [e["edgeId"] for e in state["edgeStates"]] == ["a-b", "b-c"]
    assert (first.x_m, first.y_m, first.yaw_rad, first.max_speed_mps) == (3.0, 0.0, 1.5, 0.3)
    (second,) = goals(reach(vehicle, first))
    assert (second.x_m, second.y_m, second.yaw_rad, second.max_speed_mps) == (3.0, 2.0, None, None)
    assert state_of(vehicle)["lastNodeId"] == "b"
    assert goals(reach(vehicle, second)) == []
    state = state_of(vehicle)
    assert (state["lastNodeId"], state["nodeStates"], state["edgeStates"]) == ("c", [], [])
    assert state["errors"] == [] and state["driving"] is True  # as the node has it


def test_the_horizon_waits_for_an_update_stitched_at_the_decision_point() -> None:
    vehicle, _ = _vehicle()
    a, b, c = node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0), node("c", 4, 4.0, 0.0, released=False)
    (to_b,) = goals(send(vehicle, order([a, b, c])))
    assert goals(reach(vehicle, to_b)) == []  # b is the decision point: stop there
    assert [n["released"] for n in state_of(vehicle)["nodeStates"]] == [False]
    # an update that does not start at the decision point is refused; the order stays
    elsewhere = order([node("c", 4, 4.0, 0.0), node("d", 6, 6.0, 0.0)], update=1)
    assert send(vehicle, elsewhere) == []
    refused = errors_of(vehicle)["orderUpdateError"]
    assert "not at the decision point b" in refused["errorDescription"]
    assert {"referenceKey": "orderId", "referenceValue": "o1"} in refused["errorReferences"]
    # the right update releases c and adds a horizon d
    b2, c2, d2 = (
        node("b", 2, 2.0, 0.0),
        node("c", 4, 4.0, 0.0),
        node("d", 6, 6.0, 0.0, released=False),
    )
    (to_c,) = goals(send(vehicle, order([b2, c2, d2], update=2)))
    assert (to_c.x_m, to_c.y_m) == (4.0, 0.0)
    state = state_of(vehicle)
    assert state["orderUpdateId"] == 2 and "orderUpdateError" not in errors_of(vehicle)
    assert [(n["nodeId"], n["released"]) for n in state["nodeStates"]] == [
        ("c", True),
        ("d", False),
    ]
    # sent again (the fleet control missed the state): ignored, no second goal
    assert send(vehicle, order([b2, c2, d2], update=2)) == []
    # an older update is refused and the order in hand goes on
    assert send(vehicle, order([b2, c2], update=1)) == []
    assert (
        "older than the update in hand (2)"
        in errors_of(vehicle)["orderUpdateError"]["errorDescription"]
    )
    assert vehicle.goal_id == to_c.goal_id


def test_an_update_while_driving_carries_the_goal_on_through_its_stop() -> None:
    vehicle, _ = _vehicle()
    a, b, c = node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0), node("c", 4, 4.0, 0.0, released=False)
    (to_b,) = goals(send(vehicle, order([a, b, c])))
    assert (to_b.x_m, to_b.via) == (2.0, ())  # b is the last released node: a stop
    # while the robot drives to b, an update releases c (and d as the horizon): b is now
    # driven through, the goal goes on to c over it, under a new id
    b2, c2, d2 = (
        node("b", 2, 2.0, 0.0),
        node("c", 4, 4.0, 0.0),
        node("d", 6, 6.0, 0.0, released=False),
    )
    (on,) = goals(send(vehicle, order([b2, c2, d2], update=1)))
    assert (on.x_m, on.y_m, on.via) == (4.0, 0.0, ((2.0, 0.0),))
    assert on.goal_id != to_b.goal_id and vehicle.goal_id == on.goal_id
    # the replaced goal's end is not the vehicle's: b is traversed as the new goal passes it
    canceled = GoalStatus(stamp=1.0, received=1.0, goal_id=to_b.goal_id, state="canceled")
    assert vehicle.on_goal_status(canceled, 1.0) == [] and not vehicle.paused
    passing = GoalStatus(stamp=1.5, received=1.5, goal_id=on.goal_id, state="active", via_passed=1)
    vehicle.on_goal_status(passing, 1.5)
    assert state_of(vehicle)["lastNodeId"] == "b"
    # an update whose next stop is already the goal's changes nothing: no new goal
    c3, d3, e3 = (
        node("c", 4, 4.0, 0.0),
        node("d", 6, 6.0, 0.0, position={"theta": 0.0}),
        node("e", 8, 8.0, 0.0, released=False),
    )
    (to_d,) = goals(send(vehicle, order([c3, d3, e3], update=2)))
    assert (to_d.x_m, to_d.via) == (6.0, ((4.0, 0.0),))  # d faces a heading: a stop
    d4, e4 = node("d", 6, 6.0, 0.0, position={"theta": 0.0}), node("e", 8, 8.0, 0.0)
    assert goals(send(vehicle, order([d4, e4], update=3))) == []


def test_an_update_after_the_base_is_done_continues_from_the_last_node() -> None:
    vehicle, _ = _vehicle()
    a, b = node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0)
    (to_b,) = goals(send(vehicle, order([a, b])))
    reach(vehicle, to_b)
    (to_c,) = goals(send(vehicle, order([b, node("c", 4, 2.0, 3.0)], update=1)))
    assert (to_c.x_m, to_c.y_m) == (2.0, 3.0)


@pytest.mark.parametrize(
    ("message", "kind", "said"),
    [
        (b"{not json", "validationError", "Invalid JSON"),
        (
            {**_head(), "orderId": "o", "orderUpdateId": 0, "nodes": [], "edges": []},
            "validationError",
            "nodes",
        ),
        ("serial", "validationError", "this vehicle is navd/robot-1"),
        ("edges", "validationError", "3 nodes need 2 edges"),
        ("released-edge", "validationError", "released but one of its nodes is not"),
        ("after-horizon", "validationError", "follows an unreleased one"),
        ("pick", "orderError", "action pick is not one navd performs"),
        ("trajectory", "orderError", "gives a trajectory"),
        ("far", "orderError", "the first node a is 5.00 m away"),
        ("no-position", "orderError", "node b has no nodePosition"),
    ],
)
def test_orders_navd_cannot_take_are_refused_by_name_and_nothing_drives(
    message: Any, kind: str, said: str
) -> None:
    a, b, c = node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0), node("c", 4, 4.0, 0.0)
    if message == "serial":
        message = {**order([a, b]), "serialNumber": "robot-2"}
    elif message == "edges":
        message = order([a, b, c], edges=[edge(a, b)])
    elif message == "released-edge":
        c_held = node("c", 4, 4.0, 0.0, released=False)
        message = order([a, b, c_held], edges=[edge(a, b), {**edge(b, c_held), "released": True}])
    elif message == "after-horizon":
        b_held = node("b", 2, 2.0, 0.0, released=False)
        message = order([a, b_held, c], edges=[edge(a, b_held), edge(b_held, c)])
    elif message == "pick":
        message = order([a, {**b, "actions": [action("pick", "p1", "HARD")]}])
    elif message == "trajectory":
        curve = {
            "degree": 1,
            "knotVector": [0, 0, 1, 1],
            "controlPoints": [{"x": 0, "y": 0}, {"x": 2, "y": 0}],
        }
        message = order([a, b], edges=[edge(a, b, trajectory=curve)])
    elif message == "far":
        message = order([node("a", 0, 5.0, 0.0), b])
    elif message == "no-position":
        message = order([a, {k: v for k, v in b.items() if k != "nodePosition"}])
    vehicle, _ = _vehicle()
    raw = message if isinstance(message, bytes) else json.dumps(message).encode()
    assert vehicle.on_order(raw, 0.0, HERE) == []
    error = errors_of(vehicle)[kind]
    assert said in error["errorDescription"], error
    state = state_of(vehicle)
    assert (state["orderId"], state["nodeStates"]) == ("", [])


def test_an_order_on_another_map_is_refused_by_its_node() -> None:
    vehicle, _ = _vehicle()
    a, b = node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0, position={"mapId": "level-2"})
    raw = json.dumps(order([a, b])).encode()
    assert vehicle.on_order(raw, 0.0, HERE, map_id="map") == []
    error = errors_of(vehicle)["orderError"]
    assert "node b is on map 'level-2'" in error["errorDescription"]
    assert "on map 'map'" in error["errorDescription"]
    assert {"referenceKey": "nodeId", "referenceValue": "b"} in error["errorReferences"]
    upstairs = node("a", 0, 0.0, 0.0, position={"mapId": "level-2"})
    raw = json.dumps(order([upstairs, b])).encode()
    (goal,) = goals(vehicle.on_order(raw, 0.0, HERE, map_id="level-2"))  # all on its map
    assert (goal.x_m, goal.y_m) == (2.0, 0.0)


def test_a_new_order_while_one_runs_is_refused_until_it_is_cancelled() -> None:
    vehicle, _ = _vehicle()
    (goal,) = goals(send(vehicle, order([node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0)])))
    other = order([node("x", 0, 0.0, 0.0), node("y", 2, 0.0, 2.0)], order_id="o2")
    assert send(vehicle, other) == []
    assert "order o1 is still running" in errors_of(vehicle)["orderError"]["errorDescription"]
    out = vehicle.on_instant_actions(instant(action("cancelOrder", "c1")), 1.0, HERE)
    assert out == [CancelGoal(stamp=1.0, received=1.0, goal_id=goal.goal_id)]
    state = state_of(vehicle)
    assert state["nodeStates"] == [] and state["orderId"] == "o1"  # ids are kept
    assert {"actionId": "c1", "actionType": "cancelOrder", "actionStatus": "FINISHED"} in state[
        "actionStates"
    ]
    (to_y,) = goals(send(vehicle, other))
    assert (to_y.x_m, to_y.y_m) == (0.0, 2.0) and "orderError" not in errors_of(vehicle)


def test_cancel_without_an_order_fails_with_no_order_to_cancel() -> None:
    vehicle, _ = _vehicle()
    assert vehicle.on_instant_actions(instant(action("cancelOrder", "c9")), 0.0, HERE) == []
    state = state_of(vehicle)
    assert {"actionId": "c9", "actionType": "cancelOrder", "actionStatus": "FAILED"} in state[
        "actionStates"
    ]
    error = errors_of(vehicle)["noOrderToCancel"]
    assert error["errorReferences"] == [{"referenceKey": "actionId", "referenceValue": "c9"}]


def test_a_hard_wait_on_a_node_holds_the_vehicle_for_its_duration() -> None:
    vehicle, _ = _vehicle()
    b = {**node("b", 2, 2.0, 0.0), "actions": [action("wait", "w1", "HARD", duration=5.0)]}
    (to_b,) = goals(send(vehicle, order([node("a", 0, 0.0, 0.0), b, node("c", 4, 4.0, 0.0)])))
    assert goals(reach(vehicle, to_b, now=10.0)) == []  # waiting at b
    assert {"actionId": "w1", "actionType": "wait", "actionStatus": "RUNNING"} in state_of(vehicle)[
        "actionStates"
    ]
    assert goals(vehicle.on_tick(14.9)) == []
    (to_c,) = goals(vehicle.on_tick(15.0))
    assert (to_c.x_m, to_c.y_m) == (4.0, 0.0)
    assert {"actionId": "w1", "actionType": "wait", "actionStatus": "FINISHED"} in state_of(
        vehicle
    )["actionStates"]


def _statuses(vehicle: Vehicle) -> dict[str, str]:
    return {a["actionId"]: a["actionStatus"] for a in state_of(vehicle)["actionStates"]}


def test_a_nodes_actions_run_in_order_a_hard_one_alone() -> None:
    """§6.12: SOFT and NONE actions start together; a HARD one waits for those before it and
    holds back those after it; the vehicle leaves once no SOFT or HARD action is left."""
    vehicle, _ = _vehicle()
    b = {
        **node("b", 2, 2.0, 0.0),
        "actions": [
            action("wait", "soft1", "SOFT", duration=1.0),
            action("wait", "soft2", "SOFT", duration=2.0),
            action("wait", "hard", "HARD", duration=3.0),
            action("wait", "none", "NONE", duration=10.0),
        ],
    }
    (to_b,) = goals(send(vehicle, order([node("a", 0, 0.0, 0.0), b, node("c", 4, 4.0, 0.0)])))
    assert goals(reach(vehicle, to_b, now=10.0)) == []
    assert _statuses(vehicle) == {
        "soft1": "RUNNING",
        "soft2": "RUNNING",
        "hard": "WAITING",
        "none": "WAITING",
    }
    assert goals(vehicle.on_tick(11.0)) == []  # soft1 ended; soft2 still runs: hard waits
    assert _statuses(vehicle)["hard"] == "WAITING"
    assert goals(vehicle.on_tick(12.0)) == []  # both ended: hard runs, alone
    assert _statuses(vehicle) == {
        "soft1": "FINISHED",
        "soft2": "FINISHED",
        "hard": "RUNNING",
        "none": "WAITING",
    }
    assert goals(vehicle.on_tick(14.9)) == []
    (to_c,) = goals(vehicle.on_tick(15.0))  # hard ended: the NONE wait runs while driving
    assert (to_c.x_m, to_c.y_m) == (4.0, 0.0)
    assert _statuses(vehicle)["none"] == "RUNNING"


def test_cancel_runs_until_the_robot_stands_and_fails_what_had_not_ended() -> None:
    """§6.6.3: every action not ended fails; the cancel is RUNNING while the robot still
    moves and FINISHED once it stands; a new order is taken meanwhile and driven after."""
    vehicle, _ = _vehicle()
    b = {**node("b", 2, 2.0, 0.0), "actions": [action("wait", "w", "HARD", duration=5.0)]}
    (goal,) = goals(send(vehicle, order([node("a", 0, 0.0, 0.0), b])))
    vehicle.on_tick(0.5, standing=False)  # driving toward b
    out = vehicle.on_instant_actions(instant(action("cancelOrder", "c1")), 1.0, HERE)
    assert out == [CancelGoal(stamp=1.0, received=1.0, goal_id=goal.goal_id)]
    assert _statuses(vehicle) == {"w": "FAILED", "c1": "RUNNING"}
    assert goals(vehicle.on_tick(1.2, standing=False)) == []  # still slowing down
    assert _statuses(vehicle)["c1"] == "RUNNING"
    other = order([node("x", 0, 0.0, 0.0), node("y", 2, 0.0, 2.0)], order_id="o2")
    assert goals(send(vehicle, other)) == []  # taken, not driven while the robot stops
    assert state_of(vehicle)["orderId"] == "o2"
    second = vehicle.on_instant_actions(instant(action("cancelOrder", "c2")), 1.3, HERE)
    assert [type(m) for m in second] == []  # o2 cancelled before it moved: nothing to stop
    assert _statuses(vehicle)["c1"] == "RUNNING"  # the first cancel is not failed by it
    vehicle.on_tick(1.5, standing=True)
    assert _statuses(vehicle)["c1"] == "FINISHED"
    (to_y,) = goals(
        send(vehicle, order([node("x", 0, 0.0, 0.0), node("y", 2, 0.0, 2.0)], order_id="o3"))
    )
    assert (to_y.x_m, to_y.y_m) == (0.0, 2.0)


def test_a_cancelled_orders_nodes_go_with_the_cancels_finished_not_before() -> None:
    vehicle, _ = _vehicle()
    send(vehicle, order([node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0)]))
    vehicle.on_tick(0.5, standing=False)
    vehicle.on_instant_actions(instant(action("cancelOrder", "c1")), 1.0, HERE)
    running = state_of(vehicle)
    assert [n["nodeId"] for n in running["nodeStates"]] == ["b"]  # still RUNNING: still shown
    vehicle.on_tick(1.5, standing=True)
    finished = state_of(vehicle)
    assert finished["nodeStates"] == [] and finished["edgeStates"] == []
    assert _statuses(vehicle)["c1"] == "FINISHED"


def test_a_pause_is_finished_only_once_the_robot_stands() -> None:
    vehicle, _ = _vehicle()
    send(vehicle, order([node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0)]))
    vehicle.on_tick(0.5, standing=False)  # driving at speed
    vehicle.on_instant_actions(instant(action("startPause", "p1", "HARD")), 1.0, HERE)
    assert _statuses(vehicle)["p1"] == "RUNNING"
    assert state_of(vehicle)["paused"] is True
    vehicle.on_tick(1.3, standing=False)  # still braking
    assert _statuses(vehicle)["p1"] == "RUNNING"
    vehicle.on_tick(1.6, standing=True)
    assert _statuses(vehicle)["p1"] == "FINISHED"


def test_a_cancel_ends_in_time_when_the_robot_is_never_seen_standing() -> None:
    vehicle, _ = _vehicle()
    send(vehicle, order([node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0)]))
    vehicle.on_tick(0.5, standing=False)
    vehicle.on_instant_actions(instant(action("cancelOrder", "c1", "HARD")), 1.0, HERE)
    vehicle.on_tick(1.0 + CANCEL_STOP_S - 0.1, standing=False)  # its pose stopped coming
    assert _statuses(vehicle)["c1"] == "RUNNING"
    vehicle.on_tick(1.0 + CANCEL_STOP_S, standing=False)
    assert _statuses(vehicle)["c1"] == "FINISHED"
    other = order([node("x", 0, 0.0, 0.0), node("y", 2, 0.0, 2.0)], order_id="o2")
    assert len(goals(send(vehicle, other))) == 1


def test_an_edges_actions_follow_the_blocking_rules_before_the_robot_sets_off() -> None:
    vehicle, _ = _vehicle()
    a, b = node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0)
    waits = [action("wait", "e1", "HARD", duration=1.0), action("wait", "e2", "HARD", duration=1.0)]
    assert goals(send(vehicle, order([a, b], edges=[edge(a, b, actions=waits)]))) == []
    assert _statuses(vehicle) == {"e1": "RUNNING", "e2": "WAITING"}
    assert goals(vehicle.on_tick(1.0)) == []  # e1 ended: e2 runs, alone, still standing
    assert _statuses(vehicle) == {"e1": "FINISHED", "e2": "RUNNING"}
    (to_b,) = goals(vehicle.on_tick(2.0))
    assert (to_b.x_m, to_b.y_m) == (2.0, 0.0)


def test_a_paused_vehicle_starts_no_action_until_stop_pause() -> None:
    vehicle, _ = _vehicle()
    b = {
        **node("b", 2, 2.0, 0.0),
        "actions": [
            action("wait", "s", "SOFT", duration=1.0),
            action("wait", "h", "HARD", duration=1.0),
        ],
    }
    (to_b,) = goals(send(vehicle, order([node("a", 0, 0.0, 0.0), b, node("c", 4, 4.0, 0.0)])))
    reach(vehicle, to_b, now=10.0)
    vehicle.on_instant_actions(instant(action("startPause", "p1")), 10.5, HERE)
    vehicle.on_tick(11.0)  # s ended while paused; h may not start
    assert _statuses(vehicle)["h"] == "WAITING"
    vehicle.on_instant_actions(instant(action("stopPause", "p2")), 12.0, HERE)
    assert _statuses(vehicle)["h"] == "RUNNING"
    (to_c,) = goals(vehicle.on_tick(13.0))
    assert (to_c.x_m, to_c.y_m) == (4.0, 0.0)


def test_pause_stops_the_goal_and_resume_sends_it_again() -> None:
    vehicle, _ = _vehicle()
    (goal,) = goals(send(vehicle, order([node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0)])))
    out = vehicle.on_instant_actions(instant(action("startPause", "p1")), 1.0, HERE)
    assert out == [CancelGoal(stamp=1.0, received=1.0, goal_id=goal.goal_id)]
    assert state_of(vehicle)["paused"] is True and goals(vehicle.on_tick(2.0)) == []
    (again,) = goals(vehicle.on_instant_actions(instant(action("stopPause", "p2")), 3.0, HERE))
    assert (again.x_m, again.y_m) == (2.0, 0.0) and again.goal_id != goal.goal_id
    assert state_of(vehicle)["paused"] is False


def test_init_position_state_and_factsheet_requests_and_unknown_actions() -> None:
    vehicle, asked = _vehicle()
    out = vehicle.on_instant_actions(
        instant(
            action("initPosition", "i1", x=1.0, y=2.0, theta=0.5, mapId="map", lastNodeId="n7"),
            action("stateRequest", "s1"),
            action("factsheetRequest", "f1"),
            action("startCharging", "x1"),
            action("initPosition", "i2", x="one", y=2.0, theta=0.0, mapId="map"),
        ),
        5.0,
        HERE,
    )
    assert out == [InitialPose(stamp=5.0, received=5.0, x_m=1.0, y_m=2.0, yaw_rad=0.5)]
    assert asked == ["state", "factsheet"]
    statuses = {s["actionId"]: s["actionStatus"] for s in state_of(vehicle)["actionStates"]}
    assert statuses == {
        "i1": "FINISHED",
        "s1": "FINISHED",
        "f1": "FINISHED",
        "x1": "FAILED",
        "i2": "FAILED",
    }
    assert state_of(vehicle)["lastNodeId"] == "n7"
    errors = errors_of(vehicle)
    assert (
        "startCharging is not one navd performs" in errors["unsupportedAction"]["errorDescription"]
    )
    assert "parameter x must be a number" in errors["validationError"]["errorDescription"]


def test_a_goal_that_fails_is_reported_and_tried_again() -> None:
    vehicle, _ = _vehicle()
    (goal,) = goals(send(vehicle, order([node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0)])))
    failed = GoalStatus(
        stamp=1.0, received=1.0, goal_id=goal.goal_id, state="failed", reason="no route"
    )
    assert vehicle.on_goal_status(failed, 1.0) == []
    assert "no way to node b: no route" in errors_of(vehicle)["navigationError"]["errorDescription"]
    assert goals(vehicle.on_tick(1.0 + RETRY_S - 0.1)) == []
    (again,) = goals(vehicle.on_tick(1.0 + RETRY_S))
    assert (again.x_m, again.y_m) == (2.0, 0.0)
    assert "navigationError" in errors_of(vehicle), "a retry resolves nothing yet"
    reach(vehicle, again, now=9.0)
    assert "navigationError" not in errors_of(vehicle), "the node reached resolves it"


def test_the_state_says_where_the_robot_is_and_why_it_is_held() -> None:
    vehicle, _ = _vehicle()
    robot = reports.Robot((1.0, 2.0, 7.0), 0.25, (0.0, 0.0), ("lidar silent",), True, "office")
    message = reports.state(reports.header(1, 1.8e9, MAKER, SERIAL), vehicle, robot)
    check("state", message)
    position = message["agvPosition"]
    assert position["theta"] == pytest.approx(math.remainder(7.0, math.tau))
    assert (position["mapId"], position["localizationScore"]) == ("office", 0.75)
    assert message["safetyState"] == {"eStop": "NONE", "fieldViolation": True}
    assert message["operatingMode"] == "MANUAL" and message["driving"] is False
    unknown = reports.Robot(None, math.inf, (0.0, 0.0), (), False, "office")
    blind = reports.state(reports.header(2, 1.8e9, MAKER, SERIAL), vehicle, unknown)
    check("state", blind)
    assert "agvPosition" not in blind
    check("visualization", reports.visualization(reports.header(3, 1.8e9, MAKER, SERIAL), robot))
    for what in ("ONLINE", "OFFLINE", "CONNECTIONBROKEN"):
        check("connection", reports.connection(reports.header(4, 1.8e9, MAKER, SERIAL), what))


def test_the_state_tells_the_batterys_charge_when_a_sensor_says_it() -> None:
    vehicle, _ = _vehicle()
    head = reports.header(5, 1.8e9, MAKER, SERIAL)
    measured = reports.Robot(None, math.inf, (0.0, 0.0), (), False, "office", (0.764, 12.1, True))
    message = reports.state(head, vehicle, measured)
    check("state", message)
    assert message["batteryState"] == {
        "batteryCharge": 76.4,
        "batteryVoltage": 12.1,
        "charging": True,
    }
    assert not any(i["infoType"] == "batteryUnknown" for i in message["information"])
    voltage_only = reports.Robot(
        None, math.inf, (0.0, 0.0), (), False, "office", (math.nan, 11.8, None)
    )
    partial = reports.state(head, vehicle, voltage_only)
    check("state", partial)
    assert partial["batteryState"]["batteryVoltage"] == 11.8
    assert any(i["infoType"] == "batteryUnknown" for i in partial["information"])


def test_the_factsheet_says_what_navd_is_and_does() -> None:
    config = NavdConfig()
    settings = FleetSettings.from_config(config)
    head = reports.header(0, 1.8e9, MAKER, SERIAL)
    sheet = reports.factsheet(head, config.fleet, settings.limits, settings.footprint)
    check("factsheet", sheet)
    actions = {a["actionType"]: a["actionScopes"] for a in sheet["protocolFeatures"]["agvActions"]}
    assert actions["wait"] == ["NODE", "EDGE"] and actions["cancelOrder"] == ["INSTANT"]
    assert sheet["physicalParameters"]["speedMax"] == config.robot.max_linear_speed_mps


def test_a_replaced_horizon_takes_its_actions_along_and_the_next_order_is_taken() -> None:
    vehicle, _ = _vehicle()
    waiting = {
        **node("c", 4, 4.0, 0.0, released=False),
        "actions": [action("wait", "w9", "HARD", duration=1.0)],
    }
    (to_b,) = goals(send(vehicle, order([node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0), waiting])))
    reach(vehicle, to_b)
    # an update ends the order at b: the old horizon (and its wait) is gone
    assert send(vehicle, order([node("b", 2, 2.0, 0.0)], update=1)) == []
    assert all(a["actionId"] != "w9" for a in state_of(vehicle)["actionStates"])
    second = order([node("b2", 0, 2.0, 0.0), node("y", 2, 2.0, 2.0)], order_id="o2")
    (to_y,) = goals(send(vehicle, second, Pose2(2.0, 0.0, 0.0)))  # standing at b
    assert (to_y.x_m, to_y.y_m) == (2.0, 2.0)


def test_a_pause_lasts_over_a_new_order_until_stop_pause() -> None:
    vehicle, _ = _vehicle()
    vehicle.on_instant_actions(instant(action("startPause", "p1")), 0.0, HERE)
    assert goals(send(vehicle, order([node("a", 0, 0.0, 0.0), node("b", 2, 2.0, 0.0)]))) == []
    assert state_of(vehicle)["paused"] is True
    (goal,) = goals(vehicle.on_instant_actions(instant(action("stopPause", "p2")), 1.0, HERE))
    assert (goal.x_m, goal.y_m) == (2.0, 0.0)


def test_an_instant_action_that_fails_its_schema_is_named_in_the_error() -> None:
    vehicle, _ = _vehicle()
    broken = {**_head(), "actions": [{"actionType": "startPause", "actionId": "p9"}]}  # no blocking
    assert vehicle.on_instant_actions(json.dumps(broken).encode(), 1.0, HERE) == []
    refs = errors_of(vehicle)["validationError"]["errorReferences"]
    pairs = {(r["referenceKey"], r["referenceValue"]) for r in refs}
    assert {("actionId", "p9"), ("actionType", "startPause")} <= pairs
    assert ("headerId", str(broken["headerId"])) in pairs


def test_an_order_that_fails_its_schema_is_named_in_the_error() -> None:
    vehicle, _ = _vehicle()
    broken = {**order([node("a", 0, 0.0, 0.0)]), "orderId": "o7", "edges": "none"}
    send(vehicle, broken)
    refs = errors_of(vehicle)["validationError"]["errorReferences"]
    assert {"referenceKey": "orderId", "referenceValue": "o7"} in refs


def test_an_operators_emergency_stop_is_a_remote_e_stop_in_the_state() -> None:
    vehicle, _ = _vehicle()
    held = ("emergency stop by ui",)
    robot = reports.Robot((1.0, 2.0, 0.0), 0.05, (0.0, 0.0), held, False, "map")
    message = reports.state(reports.header(1, 1.8e9, MAKER, SERIAL), vehicle, robot)
    check("state", message)
    assert message["safetyState"] == {"eStop": "REMOTE", "fieldViolation": True}


def test_nodes_with_nothing_to_do_are_driven_through_on_the_way_to_the_next_stop() -> None:
    vehicle, _ = _vehicle()
    wait = [action("wait", "w1", "HARD", duration=0.0)]
    nodes = [
        node("a", 0, 0.2, 0.0),
        node("b", 2, 2.0, 0.0, position={"allowedDeviationXY": 0.4}),
        node("c", 4, 2.0, 2.0),
        node("d", 6, 4.0, 2.0, actions=wait),  # something to do there: a stop
        node("e", 8, 6.0, 2.0),
        node("f", 10, 8.0, 2.0, released=False),  # the horizon: e is the last released
    ]
    edges = [edge(a, b) for a, b in itertools.pairwise(nodes)]
    edges[1]["maxSpeed"] = 0.4
    (first,) = goals(send(vehicle, order(nodes, edges=edges)))
    assert (first.x_m, first.y_m) == (4.0, 2.0)  # to d, through b and c
    assert first.via == ((2.0, 0.0), (2.0, 2.0)) and first.pass_within_m == 0.4
    assert first.max_speed_mps == 0.4  # the slowest edge on the way
    # b passed while the goal drives on: traversed, said in the state, nothing new to drive
    passing = GoalStatus(stamp=1.0, received=1.0, goal_id=first.goal_id, state="active")
    assert vehicle.on_goal_status(dataclasses.replace(passing, via_passed=1), 1.0) == []
    state = state_of(vehicle)
    assert state["lastNodeId"] == "b" and [n["nodeId"] for n in state["nodeStates"]] == [
        "c",
        "d",
        "e",
        "f",
    ]
    # at d: c traversed on the way, then d, whose wait holds the vehicle there
    done = dataclasses.replace(passing, state="reached", via_passed=2)
    out = vehicle.on_goal_status(done, 2.0)
    assert state_of(vehicle)["lastNodeId"] == "d"
    assert goals(out) == []  # the HARD wait runs first
    (last,) = goals(vehicle.on_tick(2.1))
    assert (last.x_m, last.y_m, last.via) == (6.0, 2.0, ())  # e: the last released node


def test_instant_actions_as_a_2_0_master_names_them_are_taken() -> None:
    # VDA 5050 2.0's JSON schema calls the list "instantActions" (2.1: "actions")
    vehicle, asked = _vehicle()
    message = {**_head(), "version": "2.0.0", "instantActions": [action("stateRequest", "s1")]}
    assert vehicle.on_instant_actions(json.dumps(message).encode(), 0.0, HERE) == []
    assert asked == ["state"] and vehicle.master_version == "2.0.0"
    assert "validationError" not in errors_of(vehicle)


def test_a_2_0_masters_spelling_of_the_nodes_allowed_deviation_is_taken() -> None:
    # vda-5050-lib's 2.0 schema names it allowedDeviationXy (2.1: allowedDeviationXY)
    vehicle, _ = _vehicle()
    nodes = [
        node("a", 0, 0.2, 0.0),
        node("b", 2, 2.0, 0.0, position={"allowedDeviationXy": 0.45}),
        node("c", 4, 4.0, 0.0),
    ]
    (goal,) = goals(send(vehicle, {**order(nodes), "version": "2.0.0"}))
    assert goal.via == ((2.0, 0.0),) and goal.pass_within_m == 0.45
