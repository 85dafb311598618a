"""The fleet: navd as a VDA 5050 vehicle on an MQTT broker (the vehicle's order logic, its
reports, the connection), an edge room that reaches the rest through the bus."""

from navd.fleet import reports
from navd.fleet.errors import BrokerUrlError, FleetError
from navd.fleet.mqtt import Broker, connect
from navd.fleet.node import FleetNode
from navd.fleet.vda5050 import MAJOR_VERSION, PROTOCOL_VERSION, Topics, timestamp
from navd.fleet.vehicle import Vehicle

__all__ = [
    "MAJOR_VERSION",
    "PROTOCOL_VERSION",
    "Broker",
    "BrokerUrlError",
    "FleetError",
    "FleetNode",
    "Topics",
    "Vehicle",
    "connect",
    "reports",
    "timestamp",
]
