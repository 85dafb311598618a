"""The fleet control speaks to each vehicle in the version the vehicle's own messages say:
2.0 to one that speaks 2.0 (vda-5050-lib's, openTCS's drop every 2.1 message), in 2.0's
spelling; 2.1.0 to any other, or to one that has not said."""

from __future__ import annotations

import json

from navd.fleetctl.view import FleetView, Vehicle, spoken


def test_a_vehicle_is_spoken_to_in_the_version_its_messages_say() -> None:
    view = FleetView("uagv")
    state = {"version": "2.0.0", "agvPosition": {"x": 1.0, "y": 2.0, "mapId": "map"}}
    heard = view.hear("uagv/v2/virtual/v1/state", json.dumps(state).encode())
    assert heard is not None
    assert heard[0].version == "2.0.0"
    assert Vehicle("navd", "r1").version == "2.1.0"  # nothing said yet
    said_2_1 = {"version": "2.1.0", "connectionState": "ONLINE"}
    heard = view.hear("uagv/v2/navd/r2/connection", json.dumps(said_2_1).encode())
    assert heard is not None and heard[0].version == "2.1.0"


def test_an_order_for_a_2_0_vehicle_spells_the_node_deviation_as_2_0_does() -> None:
    node = {"nodeId": "a", "nodePosition": {"x": 0.0, "y": 0.0, "allowedDeviationXY": 1.0}}
    order = {"version": "2.1.0", "orderId": "o", "nodes": [node, {"nodeId": "b"}]}
    old = spoken(order, "2.0.0")
    assert old["version"] == "2.0.0"
    assert old["nodes"][0]["nodePosition"] == {"x": 0.0, "y": 0.0, "allowedDeviationXy": 1.0}
    assert old["nodes"][1] == {"nodeId": "b"}
    assert spoken(order, "2.1.0")["nodes"][0] is node  # 2.1 as it was
    assert order["nodes"][0]["nodePosition"]["allowedDeviationXY"] == 1.0  # not changed
