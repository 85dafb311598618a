"""The VDA 5050 vehicle's order logic: which orders it takes, which node it drives to next,
its actions, and what its state says about them.

It knows nothing of MQTT or the bus: each input (an order, instant actions, a goal's status,
the clock) returns the bus messages to publish (goals, cancels, an initial pose) and marks
the state as changed. The rules are the specification's (2.1, §6.6): an order is a list of
nodes joined by edges, its released part (the base) is driven, its unreleased part (the
horizon) waits for an update; an update keeps the order id, raises the update id and starts
at the base's last node (the decision point), or at the last node traversed once the base
is done. Each released node is one navd goal at the node's position (its ``theta`` as the
goal's yaw, the edge's ``maxSpeed`` as its top speed); reaching it traverses the node and
runs its actions. A malformed order is refused with a "validationError", one navd cannot do
with an "orderError", a stale or disconnected update with an "orderUpdateError": the order
in hand goes on, and the error stays in the state until an order is taken.

Actions navd performs: ``wait`` on nodes and edges (``duration`` [s]; SOFT and HARD block
driving while it runs), and the instant actions ``cancelOrder``, ``startPause``,
``stopPause``, ``initPosition``, ``stateRequest`` and ``factsheetRequest``. A node's actions
start when it is traversed, in their order as blocking types allow (§6.12): NONE and SOFT
actions start together, a HARD one waits until those before it have ended and runs alone,
and those after it wait for its end; the vehicle leaves the node once no SOFT or HARD action
is left to run. ``cancelOrder`` fails every action not yet ended, stops the robot, and stays
RUNNING until the robot stands (§6.6.3). A pause (``startPause``) is a mode of the vehicle:
it lasts over new orders and cancels until ``stopPause``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError

from navd.fleet.vda5050 import Action, Edge, InstantActions, Node, Order
from navd.geometry import Pose2
from navd.lifecycle.messages import CancelGoal, Goal, GoalStatus, InitialPose, Message

__all__ = ["CANCEL_STOP_S", "INSTANT_ACTIONS", "NODE_ACTIONS", "START_DEVIATION_M", "Vehicle"]

# [m] how near the first node of a new order the robot must stand when the node gives no
# allowedDeviationXY (the order's start must be "trivially reachable").
START_DEVIATION_M = 1.0
# [s] a node goal that failed is tried again after this (the error stays reported meanwhile).
RETRY_S = 5.0
# [s] a cancelOrder is FINISHED this long after it came even if the robot was never seen
# standing (its pose no longer arriving): a robot braking from its top speed stands in 2 s.
CANCEL_STOP_S = 5.0
NODE_ACTIONS = ("wait",)
INSTANT_ACTIONS = (
    "cancelOrder",
    "startPause",
    "stopPause",
    "initPosition",
    "stateRequest",
    "factsheetRequest",
)
# Finished and failed action states kept at most (the oldest go first).
MAX_ENDED_ACTIONS = 200


@dataclass
class _ActionState:
    action: Action
    status: str = "WAITING"  # WAITING, INITIALIZING, RUNNING, FINISHED, FAILED
    result: str | None = None
    ends_s: float = math.inf  # a running wait's end


class Vehicle:
    """One vehicle's order state (see the module docstring).

    Args:
        manufacturer, serial_number: the vehicle's names; orders for another are refused.
        requests: called with "state" or "factsheet" when an instant action asks for one.
    """

    def __init__(
        self, manufacturer: str, serial_number: str, requests: Callable[[str], None]
    ) -> None:
        self.manufacturer = manufacturer
        self.serial_number = serial_number
        self._requests = requests
        self.order_id = ""
        self.order_update_id = 0
        self.last_node_id = ""
        self.last_node_sequence_id = 0
        self.nodes: list[Node] = []  # still to traverse, base then horizon
        self.edges: list[Edge] = []
        self.actions: dict[str, _ActionState] = {}
        self.errors: list[dict[str, Any]] = []
        self.paused = False
        self.held = False  # by the vehicle itself (its broker is gone, fleet.on_broker_lost)
        self.goal_id: str | None = None
        self.standing = True  # the robot's speed is below ``reports``' standing thresholds
        self._queued: list[Action] = []  # the last node's actions not started yet, in order
        self._cancelling: _ActionState | None = None  # a cancelOrder waiting for a standstill
        self._cancel_by = math.inf  # [s] when that cancel ends anyway
        self._goals = 0
        self._retry_at = math.inf
        self.changed = True  # the state has news since it was last published

    # --- inputs ---------------------------------------------------------------------------

    def on_order(
        self, raw: bytes, now: float, pose: Pose2 | None, map_id: str | None = None
    ) -> list[Message]:
        """An order message as it came from the broker; with ``map_id`` (the map the robot
        is on), an order with a node on another map is refused."""
        try:
            order = Order.model_validate_json(raw)
        except ValidationError as err:
            return self._refuse("validationError", _first_problem(err), [])
        problem = self._malformed(order)
        if problem is not None:
            return self._refuse("validationError", problem[0], problem[1], order)
        unusable = _unusable(order) or _elsewhere(order, map_id)
        if unusable is not None:
            return self._refuse("orderError", unusable[0], unusable[1], order)
        if order.orderId != self.order_id:
            return self._new_order(order, now, pose)
        if order.orderUpdateId < self.order_update_id:
            return self._refuse(
                "orderUpdateError",
                f"order {order.orderId} update {order.orderUpdateId} is older than the update "
                f"in hand ({self.order_update_id})",
                [("orderUpdateId", str(order.orderUpdateId))],
                order,
            )
        if order.orderUpdateId == self.order_update_id:
            return []  # sent again (the fleet control missed our state): nothing new
        return self._update(order, now)

    def on_instant_actions(self, raw: bytes, now: float, pose: Pose2 | None) -> list[Message]:
        """An instantActions message as it came from the broker."""
        try:
            message = InstantActions.model_validate_json(raw)
        except ValidationError as err:
            self._error("validationError", f"instantActions: {_first_problem(err)}", [])
            return []
        out: list[Message] = []
        for action in message.actions:
            out += self._instant(action, now, pose)
        return out

    def on_goal_status(self, status: GoalStatus, now: float) -> list[Message]:
        """A goal's end: the vehicle's own goal reaching its node traverses the node."""
        if status.goal_id != self.goal_id or status.state in ("active", "paused"):
            return []
        self.goal_id = None
        if status.state == "reached" and self.nodes:
            return self._traverse(now)
        if status.state == "canceled":
            if not self.paused:  # someone else's goal took over: hold the order
                self.paused = True
                self._error(
                    "orderInterrupted",
                    f"navd's goal toward node {self.nodes[0].nodeId if self.nodes else '?'} was "
                    "replaced (an operator's goal or manual driving); stopPause goes on",
                    self._node_refs(),
                )
            return []
        self._error(
            "navigationError",
            f"no way to node {self.nodes[0].nodeId if self.nodes else '?'}: {status.reason}",
            self._node_refs(),
        )
        self._retry_at = now + RETRY_S
        return []

    def hold(self, now: float) -> list[Message]:
        """Stop driving the order until ``release`` (the order and its state stay)."""
        self.held = True
        return self._cancel_goal(now)

    def release(self, now: float) -> list[Message]:
        """Go on with the order after a ``hold``."""
        self.held = False
        return self._drive(now)

    def on_tick(self, now: float, *, standing: bool = True) -> list[Message]:
        """The clock moved (and the robot is ``standing`` or not): waits may end, the next
        actions start, a cancel may be done, a failed goal may be tried again."""
        out: list[Message] = []
        self.standing = standing
        for state in self.actions.values():
            if state.status == "RUNNING" and now >= state.ends_s:
                state.status, state.ends_s = "FINISHED", math.inf
                self.changed = True
        self._start_queued(now)
        cancelling = self._cancelling
        if cancelling is not None and (standing or now >= self._cancel_by):
            cancelling.status, self._cancelling = "FINISHED", None
            self.changed = True
        if now >= self._retry_at:
            self._retry_at = math.inf
            self._clear_errors("navigationError")
            out += self._drive(now)
        elif self.goal_id is None and not self._blocked():
            out += self._drive(now)
        return out

    # --- orders ---------------------------------------------------------------------------

    def _malformed(self, order: Order) -> tuple[str, list[tuple[str, str]]] | None:
        """Why an order breaks the specification's rules, with references, or None."""
        if (order.manufacturer, order.serialNumber) != (self.manufacturer, self.serial_number):
            return (
                f"the order is for {order.manufacturer}/{order.serialNumber}, this vehicle is "
                f"{self.manufacturer}/{self.serial_number}",
                [("serialNumber", order.serialNumber)],
            )
        nodes, edges = order.nodes, order.edges
        if len(edges) != len(nodes) - 1:
            return (f"{len(nodes)} nodes need {len(nodes) - 1} edges, got {len(edges)}", [])
        for i, edge in enumerate(edges):
            a, b = nodes[i], nodes[i + 1]
            if (edge.startNodeId, edge.endNodeId) != (a.nodeId, b.nodeId):
                return (
                    f"edge {edge.edgeId} joins {edge.startNodeId} to {edge.endNodeId}, but lies "
                    f"between nodes {a.nodeId} and {b.nodeId}",
                    [("edgeId", edge.edgeId)],
                )
            if not a.sequenceId < edge.sequenceId < b.sequenceId:
                return (
                    f"edge {edge.edgeId}'s sequenceId {edge.sequenceId} is not between its "
                    f"nodes' ({a.sequenceId}, {b.sequenceId})",
                    [("edgeId", edge.edgeId)],
                )
            if edge.released and not (a.released and b.released):
                return (
                    f"edge {edge.edgeId} is released but one of its nodes is not",
                    [("edgeId", edge.edgeId)],
                )
        released = [n.released for n in nodes]
        if released and not released[0]:
            return ("the first node must be released", [("nodeId", nodes[0].nodeId)])
        if any(b and not a for a, b in itertools.pairwise(released)):
            return ("a released node follows an unreleased one (the horizon)", [])
        ids = [a.actionId for a in _actions_of(nodes, edges)]
        if len(set(ids)) != len(ids):
            return ("action ids repeat within the order", [])
        return None

    def _new_order(self, order: Order, now: float, pose: Pose2 | None) -> list[Message]:
        if self._busy():
            return self._refuse(
                "orderError",
                f"order {self.order_id} is still running: cancel it (cancelOrder) or update it",
                [("orderId", order.orderId)],
                order,
            )
        first = order.nodes[0]
        if first.nodePosition is not None:
            if pose is None:
                return self._refuse(
                    "orderError",
                    "the vehicle does not know where it is (initPosition, or wait for its "
                    "localization) to take an order",
                    [("nodeId", first.nodeId)],
                    order,
                )
            reach = first.nodePosition.allowedDeviationXY or START_DEVIATION_M
            away = math.hypot(first.nodePosition.x - pose.x, first.nodePosition.y - pose.y)
            if away > reach:
                return self._refuse(
                    "orderError",
                    f"the first node {first.nodeId} is {away:.2f} m away, more than its "
                    f"{reach:g} m deviation: an order starts where the vehicle stands",
                    [("nodeId", first.nodeId)],
                    order,
                )
        out = self._cancel_goal(now)
        self.order_id, self.order_update_id = order.orderId, order.orderUpdateId
        self.actions = {k: v for k, v in self.actions.items() if v.status not in _ENDED}
        self.nodes, self.edges = list(order.nodes), list(order.edges)
        self._register(order)
        self._clear_errors()
        self.changed = True
        return [*out, *self._traverse(now)]  # the first node: where the vehicle stands

    def _update(self, order: Order, now: float) -> list[Message]:
        first = order.nodes[0]
        if self._busy():
            base = [n for n in self.nodes if n.released]
            point = (
                (base[-1].nodeId, base[-1].sequenceId)
                if base
                else (self.last_node_id, self.last_node_sequence_id)
            )
        else:
            point = (self.last_node_id, self.last_node_sequence_id)
        if (first.nodeId, first.sequenceId) != point:
            return self._refuse(
                "orderUpdateError",
                f"update {order.orderUpdateId} starts at node {first.nodeId} "
                f"(sequence {first.sequenceId}), not at the decision point {point[0]} "
                f"(sequence {point[1]})",
                [("nodeId", first.nodeId)],
                order,
            )
        base_nodes = [n for n in self.nodes if n.released]
        base_edges = [e for e in self.edges if e.released]
        old_horizon = [n for n in self.nodes if not n.released]
        for action in _actions_of(old_horizon, [e for e in self.edges if not e.released]):
            self.actions.pop(action.actionId, None)  # the horizon is replaced, its actions too
        # the stitching node keeps its first content; the horizon is replaced
        self.nodes = base_nodes + list(order.nodes[1:]) if base_nodes else list(order.nodes[1:])
        self.edges = base_edges + list(order.edges)
        self.order_update_id = order.orderUpdateId
        self._register(order, skip_first_node=True)
        self._clear_errors()
        self.changed = True
        return [] if self.goal_id is not None else self._drive(now)

    def _register(self, order: Order, *, skip_first_node: bool = False) -> None:
        nodes = order.nodes[1:] if skip_first_node else order.nodes
        for action in _actions_of(nodes, order.edges):
            self.actions.setdefault(action.actionId, _ActionState(action))

    def _refuse(
        self,
        kind: str,
        why: str,
        refs: list[tuple[str, str]],
        order: Order | None = None,
    ) -> list[Message]:
        if order is not None:
            refs = [("orderId", order.orderId), ("orderUpdateId", str(order.orderUpdateId))] + [
                r for r in refs if r[0] not in ("orderId", "orderUpdateId")
            ]
        self._error(kind, why, refs)
        return []

    # --- driving --------------------------------------------------------------------------

    def _traverse(self, now: float) -> list[Message]:
        """The next node is reached: it is the last node, its edge is left, its actions start."""
        node = self.nodes.pop(0)
        if self.edges and self.edges[0].endNodeId == node.nodeId:
            left = self.edges.pop(0)
            for action in left.actions:
                self._finish(action.actionId)
        self.last_node_id, self.last_node_sequence_id = node.nodeId, node.sequenceId
        self._queued = list(node.actions)
        self._start_queued(now)
        self.changed = True
        return self._drive(now)

    def _drive(self, now: float) -> list[Message]:
        """A goal toward the next released node, unless paused, blocked or done."""
        if self.paused or self.held or self.goal_id is not None or self._blocked():
            return []
        if self._cancelling is not None:  # a new order drives once the cancelled one stood
            return []
        if not self.nodes or not self.nodes[0].released or self._retry_at < math.inf:
            return []
        node = self.nodes[0]
        edge = self.edges[0] if self.edges and self.edges[0].endNodeId == node.nodeId else None
        if edge is not None:  # its actions start as the node's do, before the robot sets off
            self._queued += [
                a
                for a in edge.actions
                if self.actions.get(a.actionId, _ActionState(a)).status == "WAITING"
                and a not in self._queued
            ]
            self._start_queued(now)
            if self._blocked():
                return []
        position = node.nodePosition
        assert position is not None  # orders without one are refused (``_unusable``)
        self._goals += 1
        self.goal_id = f"vda:{self.order_id}:{node.sequenceId}:{self._goals}"
        self.changed = True
        return [
            Goal(
                stamp=now,
                received=now,
                goal_id=self.goal_id,
                x_m=position.x,
                y_m=position.y,
                yaw_rad=position.theta,
                max_speed_mps=None if edge is None else edge.maxSpeed,
            )
        ]

    def _blocked(self) -> bool:
        """True while a SOFT or HARD action runs or waits its turn on the last node (the
        vehicle must stand still)."""
        return any(
            s.status == "RUNNING" and s.action.blockingType != "NONE" for s in self.actions.values()
        ) or any(a.blockingType != "NONE" for a in self._queued)

    def _busy(self) -> bool:
        """True while the vehicle has nodes to go or actions not ended (§6.6.2, step 3); a
        cancelOrder waiting for the robot to stand is not the order's (§6.6.3.1)."""
        return bool(self.nodes) or any(
            s.status not in _ENDED and s is not self._cancelling for s in self.actions.values()
        )

    def _cancel_goal(self, now: float) -> list[Message]:
        if self.goal_id is None:
            return []
        goal_id, self.goal_id = self.goal_id, None
        return [CancelGoal(stamp=now, received=now, goal_id=goal_id)]

    # --- actions --------------------------------------------------------------------------

    def _start_queued(self, now: float) -> None:
        """Start the last node's waiting actions in order, as far as blocking types allow:
        a HARD action only once nothing else runs, and nothing beside it; none while paused."""
        while self._queued and not self.paused:
            action = self._queued[0]
            running = [
                s
                for s in self.actions.values()
                if s.status == "RUNNING" and s.action.actionType not in INSTANT_ACTIONS
            ]
            if any(s.action.blockingType == "HARD" for s in running):
                return
            if action.blockingType == "HARD" and running:
                return
            self._queued.pop(0)
            self._start(action, now)
            if action.blockingType == "HARD":
                return

    def _start(self, action: Action, now: float) -> None:
        state = self.actions.setdefault(action.actionId, _ActionState(action))
        if state.status != "WAITING":
            return
        if action.actionType == "wait":
            duration = action.parameter("duration")
            state.status = "RUNNING"
            state.ends_s = now + float(duration)
        self.changed = True

    def _finish(self, action_id: str) -> None:
        state = self.actions.get(action_id)
        if state is not None and state.status not in _ENDED:
            state.status, state.ends_s = "FINISHED", math.inf
            self.changed = True

    def _instant(self, action: Action, now: float, pose: Pose2 | None) -> list[Message]:
        busy = self._busy()  # before this action joins the states
        state = _ActionState(action, status="RUNNING")
        self.actions[action.actionId] = state
        self._prune()
        self.changed = True
        out: list[Message] = []
        kind = action.actionType
        if kind == "cancelOrder":
            if not busy:
                state.status = "FAILED"
                self._error(
                    "noOrderToCancel",
                    "cancelOrder: there is no order running",
                    [("actionId", action.actionId)],
                )
                return []
            out = self._cancel_goal(now)
            for other in self.actions.values():
                if other not in (state, self._cancelling) and other.status not in _ENDED:
                    other.status, other.result = "FAILED", "cancelled"
            self.nodes, self.edges, self._queued = [], [], []
            if not self.standing and self._cancelling is None:  # FINISHED once it stands
                self._cancelling, self._cancel_by = state, now + CANCEL_STOP_S
                return out
        elif kind == "startPause":
            self.paused = True
            out = self._cancel_goal(now)
        elif kind == "stopPause":
            self.paused = False
            self._clear_errors("orderInterrupted")
            self._start_queued(now)
            out = self._drive(now)
        elif kind == "initPosition":
            problem = _init_position_problem(action)
            if problem is not None:
                state.status, state.result = "FAILED", problem
                self._error(
                    "validationError", f"initPosition: {problem}", [("actionId", action.actionId)]
                )
                return []
            last = action.parameter("lastNodeId")
            if isinstance(last, str):
                self.last_node_id = last
            out = [
                InitialPose(
                    stamp=now,
                    received=now,
                    x_m=float(action.parameter("x")),
                    y_m=float(action.parameter("y")),
                    yaw_rad=float(action.parameter("theta")),
                )
            ]
        elif kind in ("stateRequest", "factsheetRequest"):
            self._requests("state" if kind == "stateRequest" else "factsheet")
        else:
            state.status, state.result = "FAILED", f"navd does not perform {kind}"
            self._error(
                "unsupportedAction",
                f"instant action {kind} is not one navd performs ({', '.join(INSTANT_ACTIONS)})",
                [("actionId", action.actionId), ("actionType", kind)],
            )
            return []
        state.status = "FINISHED"
        return out

    def _prune(self) -> None:
        ended = [k for k, v in self.actions.items() if v.status in _ENDED]
        for key in ended[: max(len(ended) - MAX_ENDED_ACTIONS, 0)]:
            del self.actions[key]

    # --- errors ---------------------------------------------------------------------------

    def _error(self, kind: str, why: str, refs: list[tuple[str, str]]) -> None:
        self.errors = [e for e in self.errors if e["errorType"] != kind]
        self.errors.append(
            {
                "errorType": kind,
                "errorLevel": "WARNING",
                "errorDescription": why,
                "errorReferences": [{"referenceKey": k, "referenceValue": v} for k, v in refs],
            }
        )
        self.changed = True

    def _clear_errors(self, kind: str | None = None) -> None:
        kept = [] if kind is None else [e for e in self.errors if e["errorType"] != kind]
        if kept != self.errors:
            self.errors = kept
            self.changed = True

    def _node_refs(self) -> list[tuple[str, str]]:
        return [("nodeId", self.nodes[0].nodeId)] if self.nodes else []

    # --- state ----------------------------------------------------------------------------

    def order_state(self) -> dict[str, Any]:
        """The state message's order fields (its other fields are the node's)."""
        return {
            "orderId": self.order_id,
            "orderUpdateId": self.order_update_id,
            "lastNodeId": self.last_node_id,
            "lastNodeSequenceId": self.last_node_sequence_id,
            "nodeStates": [_node_state(n) for n in self.nodes],
            "edgeStates": [
                {"edgeId": e.edgeId, "sequenceId": e.sequenceId, "released": e.released}
                for e in self.edges
            ],
            "actionStates": [
                {
                    "actionId": s.action.actionId,
                    "actionType": s.action.actionType,
                    "actionStatus": s.status,
                    **({"resultDescription": s.result} if s.result else {}),
                }
                for s in self.actions.values()
            ],
            "paused": self.paused,
            "errors": list(self.errors),
        }


_ENDED = ("FINISHED", "FAILED")


def _node_state(node: Node) -> dict[str, Any]:
    state: dict[str, Any] = {
        "nodeId": node.nodeId,
        "sequenceId": node.sequenceId,
        "released": node.released,
    }
    if node.nodePosition is not None:
        state["nodePosition"] = node.nodePosition.model_dump(exclude_none=True)
    return state


def _unusable(order: Order) -> tuple[str, list[tuple[str, str]]] | None:
    """What in an order navd cannot do, with references, or None."""
    for node in order.nodes:
        if node.nodePosition is None:
            return (
                f"node {node.nodeId} has no nodePosition: navd drives to places, not along "
                "lines or tags",
                [("nodeId", node.nodeId)],
            )
    for edge in order.edges:
        if edge.trajectory is not None:
            return (
                f"edge {edge.edgeId} gives a trajectory: navd plans its own way between nodes",
                [("edgeId", edge.edgeId)],
            )
    for action in _actions_of(order.nodes, order.edges):
        if action.actionType not in NODE_ACTIONS:
            return (
                f"action {action.actionType} is not one navd performs on nodes and edges "
                f"({', '.join(NODE_ACTIONS)})",
                [("actionId", action.actionId), ("actionType", action.actionType)],
            )
        duration = action.parameter("duration")
        if not isinstance(duration, int | float) or not 0 <= duration <= 86400:
            return (
                f"wait action {action.actionId} needs a duration in seconds (0..86400), "
                f"got {duration!r}",
                [("actionId", action.actionId)],
            )
    return None


def _elsewhere(order: Order, map_id: str | None) -> tuple[str, list[tuple[str, str]]] | None:
    """Why ``order`` is not for a robot on map ``map_id`` (a node on another), or None."""
    if map_id is None:
        return None
    for node in order.nodes:
        position = node.nodePosition
        if position is not None and position.mapId != map_id:
            return (
                f"node {node.nodeId} is on map {position.mapId!r}; this vehicle is on map "
                f"{map_id!r} (slam.map_name) and does not switch maps",
                [("nodeId", node.nodeId)],
            )
    return None


def _actions_of(nodes: list[Node], edges: list[Edge]) -> list[Action]:
    """Every action of ``nodes`` and ``edges``, nodes' first."""
    return [a for n in nodes for a in n.actions] + [a for e in edges for a in e.actions]


def _init_position_problem(action: Action) -> str | None:
    for key in ("x", "y", "theta"):
        value = action.parameter(key)
        if not isinstance(value, int | float) or not math.isfinite(value):
            return f"parameter {key} must be a number, got {value!r}"
    return None


def _first_problem(err: ValidationError) -> str:
    problem = err.errors()[0]
    where = ".".join(str(p) for p in problem["loc"]) or "message"
    return f"{where}: {problem['msg']}"
