"""The VDA 5050 vehicle's order logic: which orders it takes, which node it drives to next,
its actions, and what its state says about them.

It knows nothing of MQTT or the bus: each input (an order, instant actions, a goal's status,
the clock) returns the bus messages to publish and marks the state as changed. The rules are
the specification's (§6.6; docs/fleet.md, "Orders"): the released base is driven, one navd
goal from stop to stop (``drive_through``), the horizon waits for an update. Refusals: a
"validationError", an "orderError", an "orderUpdateError"; the order in hand goes on.

Actions: ``wait`` on nodes and edges, and the instant actions (``action_states``: how they
start and block). A node's actions start when it is traversed; the vehicle leaves it once no
SOFT or HARD action is left to run. ``cancelOrder`` fails every action not yet ended and
stops the robot; it and ``startPause`` stay RUNNING until the robot stands (§6.6.3), the
cancelled order's nodes shown till then (a master reads none as the order done).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from pydantic import ValidationError

from navd.fleet.action_states import (
    ENDED,
    INSTANT_ACTIONS,
    ActionState,
    ActionStates,
    StandstillWait,
)
from navd.fleet.drive_through import chain_goal
from navd.fleet.error_list import ErrorList
from navd.fleet.order_reading import read_now
from navd.fleet.order_rules import (
    NODE_ACTIONS,
    actions_of,
    away_from_start,
    decision_point,
    elsewhere,
    first_problem,
    init_position_problem,
    initial_pose,
    loose_refs,
    malformed,
    taken,
    unusable,
)
from navd.fleet.vda5050 import Action, Edge, InstantActions, Node, Order
from navd.geometry import Pose2
from navd.lifecycle.messages import CancelGoal, GoalStatus, Message

__all__ = ["CANCEL_STOP_S", "INSTANT_ACTIONS", "NODE_ACTIONS", "Vehicle"]

# [s] a node goal that failed is tried again after this (the error stays reported meanwhile).
RETRY_S = 5.0
# [s] a cancelOrder is FINISHED this long after it came even if the robot was never seen
# standing (its pose no longer arriving): a robot braking from its top speed stands in 2 s.
CANCEL_STOP_S = 5.0


class Vehicle:
    """One vehicle's order state (see the module docstring).

    Args:
        manufacturer, serial_number: the vehicle's names; orders for another are refused.
        requests: called with "state" or "factsheet" when an instant action asks for one.
    """

    def __init__(
        self, manufacturer: str, serial_number: str, requests: Callable[[str], None]
    ) -> None:
        self.manufacturer, self.serial_number = manufacturer, serial_number
        self._requests = requests
        self.order_id, self.order_update_id = "", 0
        self.last_node_id, self.last_node_sequence_id = "", 0
        self.nodes: list[Node] = []  # still to traverse, base then horizon
        self.edges: list[Edge] = []
        self.actions = ActionStates()
        self.errors = ErrorList()  # reported until what caused them is resolved
        self.paused = False
        self.held = False  # by the vehicle itself (its broker is gone, fleet.on_broker_lost)
        self.goal_id: str | None = None
        self.standing = True  # the robot's speed is below ``reports``' standing thresholds
        self._cancel = StandstillWait(CANCEL_STOP_S)  # a cancelOrder, its order's nodes shown
        self._pause = StandstillWait(CANCEL_STOP_S)  # a startPause
        self._goals = 0
        self._retry_at = math.inf
        self.changed = True  # the state has news since it was last published
        self.master_version = ""  # the VDA 5050 version of the master's last message read
        self._via, self._passed = 0, 0  # nodes the goal drives through; of them passed
        self.blocked: Callable[[float, float], bool] | None = None  # where it cannot stand

    # --- inputs ---------------------------------------------------------------------------

    def on_order(
        self,
        raw: bytes,
        now: float,
        pose: Pose2 | None,
        map_id: str | None = None,
        read: Order | ValidationError | None = None,
    ) -> list[Message]:
        """An order as it came (``read``: as ``order_reading`` read it; None: read now); with
        ``map_id``, a node on another map or on an obstacle (``blocked``) refuses it."""
        order = read if read is not None else read_now(raw)
        if isinstance(order, ValidationError):
            return self._refuse("validationError", first_problem(order), loose_refs(raw))
        self.master_version = order.version
        problem = malformed(order, self.manufacturer, self.serial_number)
        if problem is not None:
            return self._refuse("validationError", *problem, order)
        problem = unusable(order) or elsewhere(order, map_id) or taken(order, self.blocked)
        if problem is not None:
            return self._refuse("orderError", *problem, order)
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
            why = f"instantActions: {first_problem(err)}"
            self._error("validationError", why, loose_refs(raw))
            return []
        self.master_version = message.version
        out: list[Message] = []
        for action in message.actions:
            out += self._instant(action, now, pose)
        return out

    def refuse_unread(self, what: str, size: int, limit: int) -> None:
        """A message of ``size`` bytes over ``limit`` was dropped unread: a validationError."""
        why = f"{what} of {size} bytes not read: over fleet.max_message_bytes ({limit})"
        self._error("validationError", why, [])

    def on_goal_status(self, status: GoalStatus, now: float) -> list[Message]:
        """The vehicle's own goal: each node it drove through traverses that node, its end
        at its node traverses the node."""
        mine = status.goal_id == self.goal_id
        out: list[Message] = []
        while mine and self._passed < min(status.via_passed, self._via) and self.nodes:
            self._passed += 1
            out += self._traverse(now)  # (no goal yet: one is driving)
        if not mine or status.state in ("active", "paused"):
            return out
        self.goal_id = None
        if status.state == "reached" and self.nodes:
            return out + self._traverse(now)
        node = self.nodes[0].nodeId if self.nodes else "?"
        refs = [("nodeId", node)] if self.nodes else []
        if status.state == "canceled":
            if not self.paused:  # someone else's goal took over: hold the order
                self.paused = True
                self._error(
                    "orderInterrupted",
                    f"navd's goal toward node {node} was replaced (an operator's goal or "
                    "manual driving); stopPause goes on",
                    refs,
                )
            return []
        self._error("navigationError", f"no way to node {node}: {status.reason}", refs)
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
        self.changed |= self.actions.end_waits(now)
        self._start_queued(now)
        if self._cancel.due(standing, now):
            self._cancel.end()
            if self.order_id == self._cancel.order_id:  # (not a new order taken meanwhile)
                self.nodes, self.edges = [], []
            self.changed = True
        if self._pause.due(standing, now):
            self.changed |= self._pause.end()
        if now >= self._retry_at:  # (its navigationError stays until the node is reached)
            self._retry_at = math.inf
            out += self._drive(now)
        elif self.goal_id is None and not self._blocked():
            out += self._drive(now)
        return out

    def _new_order(self, order: Order, now: float, pose: Pose2 | None) -> list[Message]:
        if self._busy():
            return self._refuse(
                "orderError",
                f"order {self.order_id} is still running: cancel it (cancelOrder) or update it",
                [("orderId", order.orderId)],
                order,
            )
        problem = away_from_start(order, pose)
        if problem is not None:
            return self._refuse("orderError", *problem, order)
        out = self._cancel_goal(now)
        self.order_id, self.order_update_id = order.orderId, order.orderUpdateId
        self.actions.forget_ended()
        self.nodes, self.edges = list(order.nodes), list(order.edges)
        self.actions.register(actions_of(order.nodes, order.edges))
        self._clear_errors()
        self.changed = True
        return [*out, *self._traverse(now)]  # the first node: where the vehicle stands

    def _update(self, order: Order, now: float) -> list[Message]:
        first = order.nodes[0]
        last = (self.last_node_id, self.last_node_sequence_id)
        point = decision_point(self.nodes, last) if self._busy() else last
        if (first.nodeId, first.sequenceId) != point:
            why = (
                f"update {order.orderUpdateId} starts at node {first.nodeId} (sequence "
                f"{first.sequenceId}), not at the decision point {point[0]} (sequence {point[1]})"
            )
            return self._refuse("orderUpdateError", why, [("nodeId", first.nodeId)], order)
        base_nodes = [n for n in self.nodes if n.released]
        base_edges = [e for e in self.edges if e.released]
        old_horizon = [n for n in self.nodes if not n.released]
        for action in actions_of(old_horizon, [e for e in self.edges if not e.released]):
            self.actions.states.pop(action.actionId, None)  # the horizon goes, its actions too
        # the stitching node keeps its first content; the horizon is replaced
        self.nodes = base_nodes + list(order.nodes[1:]) if base_nodes else list(order.nodes[1:])
        self.edges = base_edges + list(order.edges)
        self.order_update_id = order.orderUpdateId
        self.actions.register(actions_of(order.nodes[1:], order.edges))  # (the stitch's kept)
        self._clear_errors()
        self.changed = True
        if self.goal_id is None:
            return self._drive(now)
        # the goal in hand carried on past its stop if this made that a node to drive through
        further = chain_goal(self.nodes, self.edges, "", now)[1] > self._via - self._passed
        return self._goal(now) if further else []

    def _refuse(
        self, kind: str, why: str, refs: list[tuple[str, str]], order: Order | None = None
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
        self._clear_errors("navigationError")
        if self.edges and self.edges[0].endNodeId == node.nodeId:
            left = self.edges.pop(0)
            for action in left.actions:
                self.changed |= self.actions.finish(action.actionId)
        self.last_node_id, self.last_node_sequence_id = node.nodeId, node.sequenceId
        self.actions.queued = list(node.actions)
        self._start_queued(now)
        self.changed = True
        return self._drive(now)

    def _drive(self, now: float) -> list[Message]:
        """A goal toward the next released node, unless paused, blocked or done."""
        cancelling = self._cancel.action is not None  # (a new order drives once it stood)
        if self.paused or self.held or self.goal_id is not None or self._blocked() or cancelling:
            return []
        if not self.nodes or not self.nodes[0].released or self._retry_at < math.inf:
            return []
        node = self.nodes[0]
        edge = self.edges[0] if self.edges and self.edges[0].endNodeId == node.nodeId else None
        if edge is not None:  # its actions start as the node's do, before the robot sets off
            queued = self.actions.queued
            queued += [a for a in edge.actions if self.actions.waiting(a) and a not in queued]
            self._start_queued(now)
            if self._blocked():
                return []
        return self._goal(now)

    def _goal(self, now: float) -> list[Message]:
        """The goal from the next node to the first stop, passing the nodes before it."""
        self._goals += 1
        self.goal_id = f"vda:{self.order_id}:{self.nodes[0].sequenceId}:{self._goals}"
        self.changed = True
        goal, self._via = chain_goal(self.nodes, self.edges, self.goal_id, now)  # through nodes
        self._passed = 0
        return [goal]

    def _blocked(self) -> bool:
        """True while a SOFT or HARD action runs or waits its turn on the last node (the
        vehicle must stand still)."""
        return self.actions.blocking()

    def _busy(self) -> bool:
        """True while the vehicle has nodes to go or actions not ended (§6.6.2, step 3); a
        cancelOrder waiting for the robot to stand is not the order's (§6.6.3.1)."""
        cancelled = self._cancel.action is not None and self.order_id == self._cancel.order_id
        return (bool(self.nodes) and not cancelled) or any(
            s.status not in ENDED and s is not self._cancel.action for s in self.actions.values()
        )

    def _cancel_goal(self, now: float) -> list[Message]:
        if self.goal_id is None:
            return []
        goal_id, self.goal_id = self.goal_id, None
        return [CancelGoal(stamp=now, received=now, goal_id=goal_id)]

    # --- actions --------------------------------------------------------------------------

    def _start_queued(self, now: float) -> None:
        """Start the last node's waiting actions in order, as far as blocking types allow;
        none while paused."""
        if not self.paused:
            self.changed |= self.actions.start_queued(now)

    def _instant(self, action: Action, now: float, pose: Pose2 | None) -> list[Message]:
        busy = self._busy()  # before this action joins the states
        state = self.actions.instant(action)
        self.changed = True
        out: list[Message] = []
        kind = action.actionType
        if kind == "cancelOrder":
            if not busy:
                why = "cancelOrder: there is no order running"
                return self._fail(state, "noOrderToCancel", why, None)
            out = self._cancel_goal(now)
            self._clear_errors("navigationError")  # no node left to find a way to
            for other in self.actions.values():
                if other not in (state, self._cancel.action) and other.status not in ENDED:
                    other.status, other.result = "FAILED", "cancelled"
            self.actions.queued = []
            if not self.standing and self._cancel.action is None:  # FINISHED once it stands,
                self._cancel.begin(state, now, self.order_id)  # its nodes shown till then
                return out
            self.nodes, self.edges = [], []
        elif kind == "startPause":
            self.paused = True
            out = self._cancel_goal(now)
            if not self.standing:  # FINISHED once the robot stands (§6.8.2), RUNNING till then
                self._pause.begin(state, now, self.order_id)
                return out
        elif kind == "stopPause":
            self.changed |= self._pause.end()
            self.paused = False
            self._clear_errors("orderInterrupted")
            self._start_queued(now)
            out = self._drive(now)
        elif kind == "initPosition":
            problem = init_position_problem(action)
            if problem is not None:
                return self._fail(state, "validationError", f"initPosition: {problem}", problem)
            last = action.parameter("lastNodeId")
            if isinstance(last, str):
                self.last_node_id = last
            out = [initial_pose(action, now)]
        elif kind in ("stateRequest", "factsheetRequest"):
            self._requests("state" if kind == "stateRequest" else "factsheet")
        else:
            why = f"instant action {kind} is not one navd performs ({', '.join(INSTANT_ACTIONS)})"
            result = f"navd does not perform {kind}"
            return self._fail(state, "unsupportedAction", why, result, typed=True)
        state.status = "FINISHED"
        return out

    def _fail(
        self, state: ActionState, kind: str, why: str, result: str | None, *, typed: bool = False
    ) -> list[Message]:
        """An instant action that failed: FAILED with ``result``, and the error ``kind``
        naming it (``typed``: its type too)."""
        state.status, state.result = "FAILED", result
        refs = [("actionId", state.action.actionId)]
        self._error(kind, why, refs + [("actionType", state.action.actionType)] * typed)
        return []

    def _error(self, kind: str, why: str, refs: list[tuple[str, str]]) -> None:
        self.errors.report(kind, why, refs)
        self.changed = True

    def _clear_errors(self, kind: str | None = None) -> None:
        self.changed |= self.errors.clear(kind)
