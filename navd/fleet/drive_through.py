"""Which of an order's next nodes the robot drives through rather than stops at, and the one
navd goal that takes it over them.

A node is a stop when something must happen there: it has actions, a heading to face
(``theta``), is the last released node, or the edge after it has actions. Every other node
is passed on the way to the next stop, within its allowed deviation (VDA 5050 §6.6.4: a node
is traversed once the vehicle is within ``allowedDeviationXY`` of it), so the robot neither
tapers down nor stops there: the goal goes to the next stop with the nodes before it as
points to pass (``Goal.via``). A chain is at most ``MAX_CHAIN_M`` long, so that its route is
planned at full resolution.
"""

from __future__ import annotations

import math

from navd.fleet.vda5050 import Edge, Node
from navd.lifecycle.messages import Goal

__all__ = ["DEFAULT_PASS_M", "MAX_CHAIN_M", "chain_goal"]

MAX_CHAIN_M = 15.0  # [m] the longest run of nodes one goal drives over
DEFAULT_PASS_M = 0.5  # [m] a node without allowedDeviationXY is passed this close
MIN_PASS_M = 0.05  # [m] a node asking for less is still passed this close


def _edge_to(edges: list[Edge], node: Node) -> Edge | None:
    return next((e for e in edges if e.endNodeId == node.nodeId), None)


def _passable(node: Node, after: Node, edges: list[Edge]) -> bool:
    """Whether ``node`` can be driven through on the way to ``after``."""
    edge = _edge_to(edges, after)
    return (
        not node.actions
        and node.nodePosition is not None
        and node.nodePosition.theta is None
        and after.released
        and after.nodePosition is not None
        and (edge is None or not edge.actions)
    )


def chain_goal(nodes: list[Node], edges: list[Edge], goal_id: str, now: float) -> tuple[Goal, int]:
    """The goal over the nodes from ``nodes[0]`` (the next node, released, with a position)
    to the first stop, and how many nodes it passes on the way (0: it goes to ``nodes[0]``)."""
    via: list[Node] = []
    length = 0.0
    while len(via) + 1 < len(nodes) and _passable(nodes[len(via)], nodes[len(via) + 1], edges):
        here, there = nodes[len(via)].nodePosition, nodes[len(via) + 1].nodePosition
        assert here is not None and there is not None
        step = math.hypot(there.x - here.x, there.y - here.y)
        if length + step > MAX_CHAIN_M:
            break
        length += step
        via.append(nodes[len(via)])
    stop = nodes[len(via)]
    position = stop.nodePosition
    assert position is not None  # orders without one are refused
    speeds = [e.maxSpeed for n in (*via, stop) if (e := _edge_to(edges, n)) and e.maxSpeed]
    deviations = [_pass_m(n) for n in via]
    goal = Goal(
        stamp=now,
        received=now,
        goal_id=goal_id,
        x_m=position.x,
        y_m=position.y,
        yaw_rad=position.theta,
        max_speed_mps=min(speeds) if speeds else None,
        via=tuple((n.nodePosition.x, n.nodePosition.y) for n in via if n.nodePosition),
        pass_within_m=min(deviations) if deviations else DEFAULT_PASS_M,
    )
    return goal, len(via)


def _pass_m(node: Node) -> float:
    deviation = node.nodePosition.allowedDeviationXY if node.nodePosition else None
    return DEFAULT_PASS_M if not deviation else max(deviation, MIN_PASS_M)
