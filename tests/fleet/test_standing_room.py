"""An order's node on a wall is refused when the order comes, naming the node: the map the
robot is on says where its disc fits."""

from __future__ import annotations

import json

import numpy as np

from navd.fleet.standing_room import StandingRoom
from navd.lifecycle.messages import MapUpdate
from tests.fleet.test_vehicle import HERE, _vehicle, errors_of, goals, node, order


def _room() -> MapUpdate:
    """A 4 m x 3 m room at 5 cm: free inside, a wall along x = 2 m, unknown beyond y = 2 m."""
    cells = np.zeros((60, 80), np.int8)
    cells[:, 40] = 100  # the wall: x in [2.0, 2.05)
    cells[40:, :] = -1
    return MapUpdate(
        stamp=0.0,
        received=0.0,
        revision=1,
        resolution_m=0.05,
        origin_x_m=0.0,
        origin_y_m=0.0,
        occupancy=cells,
    )


def test_the_robots_disc_fits_only_clear_of_walls() -> None:
    room = StandingRoom(radius_m=0.2)
    assert not room.blocked(1.0, 1.0)  # no map yet: nothing refused
    room.take(_room())
    assert room.blocked(2.02, 1.0)  # on the wall
    assert room.blocked(1.85, 1.0)  # 0.15 m from it: the 0.2 m disc overlaps it
    assert not room.blocked(1.7, 1.0)  # 0.3 m from it
    assert not room.blocked(1.0, 2.5)  # unknown is no reason to refuse
    assert not room.blocked(10.0, 10.0)  # off the map


def test_an_order_to_a_node_on_a_wall_is_refused_at_once_naming_it() -> None:
    vehicle, _ = _vehicle()
    room = StandingRoom(radius_m=0.2)
    room.take(_room())
    vehicle.blocked = room.blocked
    nodes = [node("a", 0, HERE.x, HERE.y), node("b", 2, 1.0, 1.0), node("wall", 4, 2.02, 1.0)]
    out = vehicle.on_order(json.dumps(order(nodes)).encode(), 0.0, HERE)
    assert goals(out) == []  # nothing drives
    error = errors_of(vehicle)["orderError"]
    assert "node wall at (2.02, 1.00) is on an obstacle" in error["errorDescription"]
    assert {"referenceKey": "nodeId", "referenceValue": "wall"} in error["errorReferences"]
    clear = [node("a", 0, HERE.x, HERE.y), node("b", 2, 1.0, 1.0)]
    assert goals(vehicle.on_order(json.dumps(order(clear, order_id="o2")).encode(), 0.0, HERE))
