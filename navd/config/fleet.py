"""The fleet side: navd as a VDA 5050 vehicle on an MQTT broker (off by default)."""

from __future__ import annotations

import re
from typing import Literal
from urllib.parse import SplitResult, urlsplit

from pydantic import Field, field_validator, model_validator

from navd.config.fields import Section, restart

__all__ = ["FleetConfig", "split_broker_url"]

# VDA 5050 topic levels (manufacturer, serial number, interface name) may not hold MQTT's
# wildcards or separators; the specification asks for A-Z a-z 0-9 _ . : - only.
_TOPIC_LEVEL = re.compile(r"^[A-Za-z0-9_.:\-]{1,64}$")


def split_broker_url(url: str) -> SplitResult:
    """``url``'s parts, checked to be ``mqtt://HOST[:PORT]`` or ``mqtts://HOST[:PORT]`` with a
    port that parses (a user and password may come before the host).

    Raises:
        ValueError: it is not, saying what to write instead.
    """
    try:
        parts = urlsplit(url)
        parts.port  # noqa: B018 - parses the port, raising on a bad one
    except ValueError as err:
        raise ValueError(f"broker URL {url!r}: {err}") from err
    if parts.scheme not in ("mqtt", "mqtts") or not parts.hostname:
        raise ValueError(f"broker URL {url!r} must be mqtt://HOST[:PORT] or mqtts://HOST[:PORT]")
    return parts


class FleetConfig(Section):
    """A VDA 5050 2.1 vehicle over MQTT: ``[fleet]`` with the broker and the vehicle's names."""

    enabled: bool = Field(False, **restart("be a VDA 5050 vehicle on the broker below"))
    broker_url: str = Field(
        "mqtt://127.0.0.1:1883",
        examples=["mqtts://fleet.example.com:8883"],
        **restart("the MQTT broker: mqtt://HOST[:PORT] or mqtts://HOST[:PORT] (TLS)"),
    )
    username: str | None = Field(None, max_length=256, **restart("the broker's user name"))
    password: str | None = Field(
        None, max_length=1024, **restart("the broker user's password", secret=True)
    )
    ca_file: str | None = Field(
        None, **restart("PEM file of the CA that signed the broker's certificate (mqtts)")
    )
    cert_file: str | None = Field(
        None, **restart("PEM file of this vehicle's client certificate (mqtts, optional)")
    )
    key_file: str | None = Field(
        None, **restart("PEM file of the client certificate's private key", secret=True)
    )
    interface_name: str = Field("uagv", **restart("the topics' first level (VDA 5050: uagv)"))
    manufacturer: str = Field("navd", **restart("the vehicle's manufacturer, in its topics"))
    serial_number: str = Field(
        "navd-robot", **restart("the vehicle's serial number, in its topics (unique per fleet)")
    )
    on_broker_lost: Literal["hold", "continue"] = Field(
        "hold",
        description="while the broker is unreachable: hold the robot still, or go on with the "
        "order it has",
    )
    state_interval_s: float = Field(
        30.0,
        gt=0,
        le=30,
        description="[s] the state is published on every change and at least this often",
    )
    visualization_rate_hz: float = Field(
        5.0,
        ge=0,
        le=50,
        description="[Hz] how often the position is published (0: never); a fleet control "
        "pacing a group carries each position on until the next, so a fresher one keeps the "
        "group's shape better (office triangle: largest shape error 0.19 m at 5 Hz, 0.23-0.26 "
        "m at 2 Hz)",
    )
    keepalive_s: int = Field(
        10, ge=2, le=600, **restart("[s] MQTT keep-alive: a silent vehicle is broken after 1.5x")
    )
    protocol_version: Literal["auto", "2.1.0", "2.0.0"] = Field(
        "auto",
        description="the VDA 5050 version of what navd sends: auto answers in the version of "
        "the master's last order or instant action (2.0 masters such as vda-5050-lib 1.x or "
        "openTCS's adapter drop 2.1.0 messages), 2.1.0 until one came; or always this one",
    )
    max_message_bytes: int = Field(
        1_048_576,
        ge=65_536,
        le=67_108_864,
        description="[bytes] the largest MQTT message taken (orders, instant actions, other "
        "vehicles' positions): a larger one is refused, with a validationError on the state, "
        "because parsing it holds the event loop (a 1 MiB order takes ~0.1 s on the board); "
        "an MQTT 5 broker is asked not to send one over 4x this at all (3.1.1 brokers send "
        "it, and it is read before it is refused); the factsheet gives it to masters as msgLen",
    )

    @field_validator("interface_name", "manufacturer", "serial_number")
    @classmethod
    def _topic_level(cls, value: str) -> str:
        if not _TOPIC_LEVEL.match(value):
            raise ValueError(
                f"{value!r} cannot be an MQTT topic level: use 1-64 letters, digits and _ . : -"
            )
        return value

    @model_validator(mode="after")
    def _broker(self) -> FleetConfig:
        try:
            url = split_broker_url(self.broker_url)
        except ValueError as err:
            raise ValueError(f"fleet.broker_url: {err}") from err
        if (self.cert_file is None) != (self.key_file is None):
            raise ValueError("fleet.cert_file and fleet.key_file must be set together")
        if url.scheme == "mqtt" and (self.ca_file or self.cert_file):
            raise ValueError(
                "fleet.ca_file and fleet.cert_file need TLS: use an mqtts:// broker_url"
            )
        return self
