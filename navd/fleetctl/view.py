"""What the fleet control hears of the vehicles on the broker (their connection and state)
and the messages it sends them besides orders: instant actions, each topic with its own
headerId count."""

from __future__ import annotations

import asyncio
import json
import time
import uuid
from dataclasses import dataclass, field
from typing import Any

import aiomqtt

from navd.fleet import MAJOR_VERSION, PROTOCOL_VERSION, Broker, connect, timestamp

__all__ = [
    "HEADERS",
    "QOS",
    "FleetView",
    "HeaderIds",
    "Vehicle",
    "fleet_view",
    "instant_action",
    "master_client",
    "spoken",
    "state_request",
]

# [s] how long ``fleet_view`` listens for the vehicles' retained and fresh messages
LISTEN_S = 1.5
QOS = 0  # VDA 5050 §6.2: orders and instant actions at QoS 0


class HeaderIds:
    """The headerId of each topic: each (so each vehicle's orders and its instant actions
    apart) counts its own messages from 1 (VDA 5050 §6.1)."""

    def __init__(self) -> None:
        self._last: dict[str, int] = {}

    def next(self, topic: str) -> int:
        """The next headerId on ``topic``."""
        self._last[topic] = self._last.get(topic, 0) + 1
        return self._last[topic]


HEADERS = HeaderIds()  # this master's, for every vehicle it talks to


@dataclass
class Vehicle:
    """A vehicle as the fleet control last heard it."""

    manufacturer: str
    serial: str
    connection: str = "unknown"
    state: dict[str, Any] | None = None
    said_version: str = ""  # the protocol version of its last message

    @property
    def name(self) -> str:
        return f"{self.manufacturer}/{self.serial}"

    @property
    def version(self) -> str:
        """The VDA 5050 version to speak to it: 2.0.0 to a vehicle that speaks 2.0 (and drops
        2.1 messages), else navd's."""
        return "2.0.0" if self.said_version.startswith("2.0") else PROTOCOL_VERSION

    @property
    def map_id(self) -> str | None:
        """The map its position is on (``agvPosition.mapId``), None if not said."""
        where = (self.state or {}).get("agvPosition")
        map_id = where.get("mapId") if isinstance(where, dict) else None
        return map_id if isinstance(map_id, str) else None

    @property
    def position(self) -> tuple[float, float] | None:
        where = (self.state or {}).get("agvPosition")
        try:
            return None if not isinstance(where, dict) else (float(where["x"]), float(where["y"]))
        except (KeyError, TypeError, ValueError):
            return None  # a malformed position: none known


@dataclass
class FleetView:
    """Every vehicle heard of, by "manufacturer/serial"."""

    interface: str
    vehicles: dict[str, Vehicle] = field(default_factory=dict)

    def hear(self, topic: str, payload: bytes) -> tuple[Vehicle, str] | None:
        """Take a message; the vehicle and the topic's last level, or None if not a
        vehicle's (or malformed)."""
        levels = topic.split("/")
        if len(levels) != 5:
            return None
        try:
            body = json.loads(payload)
        except (ValueError, RecursionError):
            return None
        if not isinstance(body, dict):
            return None
        key = f"{levels[2]}/{levels[3]}"
        vehicle = self.vehicles.setdefault(key, Vehicle(levels[2], levels[3]))
        if isinstance(said := body.get("version"), str):
            vehicle.said_version = said
        if levels[4] == "connection":
            vehicle.connection = str(body.get("connectionState", "unknown"))
        elif levels[4] == "state":
            vehicle.state = body
        return vehicle, levels[4]


def master_client(broker_url: str) -> aiomqtt.Client:
    """A connection for the fleet control, under a name of its own on the broker.

    Raises:
        BrokerUrlError: the URL is not an MQTT broker's.
    """
    return connect(Broker.of_url(broker_url), f"navd-fleet-{uuid.uuid4().hex[:8]}")


async def fleet_view(
    broker_url: str, interface: str = "uagv", listen_s: float = LISTEN_S
) -> FleetView:
    """Every vehicle on the broker: their retained connection, and their state within
    ``listen_s`` (each ONLINE one is asked for it)."""
    view = FleetView(interface)
    prefix = f"{interface}/{MAJOR_VERSION}"
    async with master_client(broker_url) as client:
        await client.subscribe(f"{prefix}/+/+/connection", qos=1)
        await client.subscribe(f"{prefix}/+/+/state", qos=1)
        asked: set[str] = set()
        loop = asyncio.get_running_loop()
        deadline = loop.time() + listen_s
        while (left := deadline - loop.time()) > 0:
            try:
                message = await asyncio.wait_for(anext(client.messages), left)
            except TimeoutError:
                break
            heard = view.hear(str(message.topic), bytes(message.payload))
            if heard is not None and heard[0].connection == "ONLINE" and heard[0].name not in asked:
                asked.add(heard[0].name)
                await state_request(client, prefix, heard[0])
    return view


def spoken(order: dict[str, Any], version: str) -> dict[str, Any]:
    """``order`` as a vehicle of ``version`` reads it: its version said, and for 2.0 each
    node's deviation under 2.0's schema spelling (``allowedDeviationXy``; 2.1:
    ``allowedDeviationXY``)."""
    out = {**order, "version": version}
    if version.startswith("2.0"):
        out["nodes"] = [_node_in_2_0(node) for node in order.get("nodes", [])]
    return out


def _node_in_2_0(node: dict[str, Any]) -> dict[str, Any]:
    position = node.get("nodePosition")
    if not isinstance(position, dict) or "allowedDeviationXY" not in position:
        return node
    moved = {k: v for k, v in position.items() if k != "allowedDeviationXY"}
    return {**node, "nodePosition": {**moved, "allowedDeviationXy": position["allowedDeviationXY"]}}


def instant_action(
    manufacturer: str,
    serial: str,
    header_id: int,
    kind: str,
    action_id: str,
    *,
    version: str = PROTOCOL_VERSION,
) -> dict[str, Any]:
    """An instantActions message of one action ``kind`` for a vehicle, in ``version`` (2.0
    names the list ``instantActions``, 2.1 ``actions``)."""
    key = "instantActions" if version.startswith("2.0") else "actions"
    return {
        "headerId": header_id,
        "timestamp": timestamp(time.time()),
        "version": version,
        "manufacturer": manufacturer,
        "serialNumber": serial,
        key: [{"actionType": kind, "actionId": action_id, "blockingType": "NONE"}],
    }


async def state_request(client: aiomqtt.Client, prefix: str, vehicle: Vehicle) -> None:
    """Ask ``vehicle`` for a fresh state (a ``stateRequest`` instant action)."""
    topic = f"{prefix}/{vehicle.manufacturer}/{vehicle.serial}/instantActions"
    message = instant_action(
        vehicle.manufacturer,
        vehicle.serial,
        HEADERS.next(topic),
        "stateRequest",
        f"state-{uuid.uuid4().hex[:8]}",
        version=vehicle.version,
    )
    await client.publish(topic, json.dumps(message), qos=QOS)
