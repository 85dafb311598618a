"""Errors raised by navd.fleet (the vehicle's VDA 5050 side and its MQTT connection)."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["BrokerUrlError", "FleetError"]


class FleetError(NavdError):
    """Base of the errors raised by navd.fleet."""


class BrokerUrlError(FleetError, ValueError):
    """A broker URL that is not ``mqtt://HOST[:PORT]`` or ``mqtts://HOST[:PORT]``."""
