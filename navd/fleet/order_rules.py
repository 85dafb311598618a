"""What makes an order one this vehicle takes (VDA 5050 2.1, §6.6): the specification's own
rules (nodes and edges that join, sequence ids in order, a base before the horizon, action
ids that do not repeat), what navd can do (places to drive to, the actions it performs), and
the map it is on. Each check returns why not, with the references the error carries, or None.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Callable

from pydantic import ValidationError

from navd.fleet.vda5050 import Action, Edge, Node, Order
from navd.geometry import Pose2
from navd.lifecycle.messages import InitialPose

__all__ = [
    "NODE_ACTIONS",
    "START_DEVIATION_M",
    "Problem",
    "actions_of",
    "away_from_start",
    "decision_point",
    "elsewhere",
    "first_problem",
    "init_position_problem",
    "initial_pose",
    "loose_refs",
    "malformed",
    "taken",
    "unusable",
]

NODE_ACTIONS = ("wait",)
# [m] how near the first node of a new order the robot must stand when the node gives no
# allowedDeviationXY (the order's start must be "trivially reachable").
START_DEVIATION_M = 1.0
# Why an order is refused, and the references its error carries: (key, value) pairs.
Problem = tuple[str, list[tuple[str, str]]]
# A refused message's references: its identity, and its first actions' ids and types.
REFERRED = ("headerId", "orderId", "orderUpdateId")
MAX_REFERRED_ACTIONS = 20


def malformed(order: Order, manufacturer: str, serial_number: str) -> Problem | None:
    """Why an order breaks the specification's rules, with references, or None."""
    if (order.manufacturer, order.serialNumber) != (manufacturer, serial_number):
        return (
            f"the order is for {order.manufacturer}/{order.serialNumber}, this vehicle is "
            f"{manufacturer}/{serial_number}",
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
    ids = [a.actionId for a in actions_of(nodes, edges)]
    if len(set(ids)) != len(ids):
        return ("action ids repeat within the order", [])
    return None


def unusable(order: Order) -> Problem | None:
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
    for action in actions_of(order.nodes, order.edges):
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


def taken(order: Order, blocked: Callable[[float, float], bool] | None) -> Problem | None:
    """The first released node whose place ``blocked`` says the robot cannot stand at (the
    map shows an obstacle there), or None."""
    if blocked is None:
        return None
    for node in order.nodes:
        where = node.nodePosition
        if node.released and where is not None and blocked(where.x, where.y):
            why = (
                f"node {node.nodeId} at ({where.x:.2f}, {where.y:.2f}) is on an obstacle of "
                "the map (a wall?): the robot cannot stand there"
            )
            return why, [("nodeId", node.nodeId)]
    return None


def elsewhere(order: Order, map_id: str | None) -> Problem | None:
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


def actions_of(nodes: list[Node], edges: list[Edge]) -> list[Action]:
    """Every action of ``nodes`` and ``edges``, nodes' first."""
    return [a for n in nodes for a in n.actions] + [a for e in edges for a in e.actions]


def init_position_problem(action: Action) -> str | None:
    for key in ("x", "y", "theta"):
        value = action.parameter(key)
        if not isinstance(value, int | float) or not math.isfinite(value):
            return f"parameter {key} must be a number, got {value!r}"
    return None


def decision_point(nodes: list[Node], last: tuple[str, int]) -> tuple[str, int]:
    """(nodeId, sequenceId) where an update to a running order must start: the last released
    node still to drive, or ``last``, the node traversed last, when none is left."""
    base = [n for n in nodes if n.released]
    return (base[-1].nodeId, base[-1].sequenceId) if base else last


def loose_refs(raw: bytes) -> list[tuple[str, str]]:
    """What a message that failed its schema can still be referred to by (``errorReferences``:
    the master must learn which message and action failed): its headerId, orderId and
    orderUpdateId, and each action's actionId and actionType, where they are there to read;
    none from what is not JSON."""
    try:
        body = json.loads(raw)
    except (ValueError, RecursionError):
        return []
    if not isinstance(body, dict):
        return []
    refs = [(key, str(body[key])) for key in REFERRED if isinstance(body.get(key), str | int)]
    actions = body.get("actions")
    for action in actions[:MAX_REFERRED_ACTIONS] if isinstance(actions, list) else []:
        if isinstance(action, dict):
            refs += [
                (key, action[key]) for key in ("actionId", "actionType")
                if isinstance(action.get(key), str)
            ]  # fmt: skip
    return refs


def first_problem(err: ValidationError) -> str:
    problem = err.errors()[0]
    where = ".".join(str(p) for p in problem["loc"]) or "message"
    return f"{where}: {problem['msg']}"


def away_from_start(order: Order, pose: Pose2 | None) -> Problem | None:
    """Why a new order cannot start where the vehicle stands (at ``pose``; None: not known),
    or None: it starts at its first node."""
    first = order.nodes[0]
    if first.nodePosition is None:
        return None
    if pose is None:
        return (
            "the vehicle does not know where it is (initPosition, or wait for its "
            "localization) to take an order",
            [("nodeId", first.nodeId)],
        )
    reach = first.nodePosition.allowedDeviationXY or START_DEVIATION_M
    away = math.hypot(first.nodePosition.x - pose.x, first.nodePosition.y - pose.y)
    if away > reach:
        return (
            f"the first node {first.nodeId} is {away:.2f} m away, more than its {reach:g} m "
            "deviation: an order starts where the vehicle stands",
            [("nodeId", first.nodeId)],
        )
    return None


def initial_pose(action: Action, now: float) -> InitialPose:
    """The pose an ``initPosition`` action (checked by ``init_position_problem``) sets."""
    return InitialPose(
        stamp=now,
        received=now,
        x_m=float(action.parameter("x")),
        y_m=float(action.parameter("y")),
        yaw_rad=float(action.parameter("theta")),
    )
