# ruff: noqa: N815 - the fields are named as the VDA 5050 schemas spell them
"""VDA 5050 2.1 on the wire: the orders and instant actions a fleet control sends (read and
checked by pydantic, field names as the specification spells them), and the header, topics
and timestamps of what the vehicle sends back.

Only what navd uses is modelled; other fields of the schemas are accepted and ignored. An
edge's ``trajectory`` (navd plans its own way) and a node without ``nodePosition`` refuse the
order by name (the specification's "orderError", ``vehicle``), as does a node on another
map than the robot's (``vehicle``); corridors and edge orientation are read as given and
not checked.
"""

from __future__ import annotations

import datetime as dt
import math
from typing import Any, Literal

from pydantic import AliasChoices, BaseModel, ConfigDict, Field

__all__ = [
    "PROTOCOL_VERSION",
    "Action",
    "Edge",
    "InstantActions",
    "Node",
    "NodePosition",
    "Order",
    "OrderHead",
    "Topics",
    "timestamp",
]

PROTOCOL_VERSION = "2.1.0"
MAJOR_VERSION = "v2"
# Bounds of what a fleet control may send, far beyond any real order (a bounded message).
MAX_NODES = 1000
MAX_ACTIONS = 100
MAX_ID_LENGTH = 256


class _Wire(BaseModel):
    """VDA 5050 objects: JSON types as the schema says, unknown fields ignored."""

    model_config = ConfigDict(extra="ignore", frozen=True, allow_inf_nan=False)


class ActionParameter(_Wire):
    key: str = Field(max_length=MAX_ID_LENGTH)
    value: Any


class Action(_Wire):
    """An action on a node, an edge, or sent on its own (instantActions)."""

    actionType: str = Field(max_length=MAX_ID_LENGTH)
    actionId: str = Field(max_length=MAX_ID_LENGTH)
    blockingType: Literal["NONE", "SOFT", "HARD"]
    actionDescription: str | None = None
    actionParameters: list[ActionParameter] = Field(default_factory=list, max_length=MAX_ACTIONS)

    def parameter(self, key: str) -> Any:
        """The value of parameter ``key``, or None."""
        return next((p.value for p in self.actionParameters if p.key == key), None)


class NodePosition(_Wire):
    """[m, m, rad] where a node is in the map frame, and how near counts as on it."""

    x: float
    y: float
    theta: float | None = Field(None, ge=-math.pi - 1e-6, le=math.pi + 1e-6)
    # 2.0's JSON schema (as vda-5050-lib carries it) spells it allowedDeviationXy
    allowedDeviationXY: float | None = Field(
        None, ge=0, validation_alias=AliasChoices("allowedDeviationXY", "allowedDeviationXy")
    )
    allowedDeviationTheta: float | None = Field(None, ge=0, le=math.pi + 1e-6)
    mapId: str = Field(max_length=MAX_ID_LENGTH)


class Node(_Wire):
    nodeId: str = Field(max_length=MAX_ID_LENGTH)
    sequenceId: int = Field(ge=0)
    released: bool
    nodePosition: NodePosition | None = None
    actions: list[Action] = Field(max_length=MAX_ACTIONS)
    nodeDescription: str | None = None


class Edge(_Wire):
    edgeId: str = Field(max_length=MAX_ID_LENGTH)
    sequenceId: int = Field(ge=0)
    released: bool
    startNodeId: str
    endNodeId: str
    maxSpeed: float | None = Field(None, gt=0)
    actions: list[Action] = Field(max_length=MAX_ACTIONS)
    trajectory: dict[str, Any] | None = None
    edgeDescription: str | None = None


class Header(_Wire):
    headerId: int = Field(ge=0)
    timestamp: str
    version: str
    manufacturer: str
    serialNumber: str


class OrderHead(Header):
    """An order's fields but its nodes and edges (``order_reading`` checks those apart)."""

    orderId: str = Field(min_length=1, max_length=MAX_ID_LENGTH)
    orderUpdateId: int = Field(ge=0)
    zoneSetId: str | None = None


class Order(OrderHead):
    nodes: list[Node] = Field(min_length=1, max_length=MAX_NODES)
    edges: list[Edge] = Field(max_length=MAX_NODES)


class InstantActions(Header):
    # 2.1's "actions"; 2.0's JSON schema (as 2.0 masters such as vda-5050-lib send it) names
    # the list "instantActions"
    actions: list[Action] = Field(
        max_length=MAX_ACTIONS, validation_alias=AliasChoices("actions", "instantActions")
    )


class Topics:
    """The vehicle's topics: ``interface/v2/manufacturer/serialNumber/<topic>``."""

    def __init__(self, interface_name: str, manufacturer: str, serial_number: str) -> None:
        self.interface = f"{interface_name}/{MAJOR_VERSION}"
        self.prefix = f"{self.interface}/{manufacturer}/{serial_number}"
        self.order = f"{self.prefix}/order"
        self.instant_actions = f"{self.prefix}/instantActions"
        self.state = f"{self.prefix}/state"
        self.visualization = f"{self.prefix}/visualization"
        self.connection = f"{self.prefix}/connection"
        self.factsheet = f"{self.prefix}/factsheet"

    def everyone(self, topic: str) -> str:
        """The subscription to ``topic`` of every vehicle of the interface."""
        return f"{self.interface}/+/+/{topic}"


def timestamp(unix_s: float) -> str:
    """ISO 8601 UTC with milliseconds, as the specification writes it (…T11:40:03.120Z)."""
    moment = dt.datetime.fromtimestamp(unix_s, tz=dt.UTC)
    return moment.strftime("%Y-%m-%dT%H:%M:%S.") + f"{moment.microsecond // 1000:03d}Z"
