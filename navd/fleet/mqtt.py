"""The one way navd opens an MQTT connection: a broker named by its URL
(``mqtt://HOST[:PORT]`` or ``mqtts://HOST[:PORT]``, with user and password in the URL or
given apart, and client certificates for TLS), as an aiomqtt client.

The vehicle (``node.FleetNode``), the fleet control (``navd fleet``) and the fleet benchmark
connect through ``connect``; what they say on the connection is theirs.

The vehicle connects with MQTT 5 and names the largest packet it takes (MQTT 5.0
§3.1.2.11.4): the broker then drops a larger message instead of sending it, so a 50 MB order
is never read (reading it held the loop that drives the wheels for half a second). A broker
that speaks only 3.1.1 refuses that (``refused_mqtt5``), and the vehicle connects again with
3.1.1.
"""

from __future__ import annotations

import ssl
from dataclasses import dataclass

import aiomqtt
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties

from navd.config import split_broker_url
from navd.fleet.errors import BrokerUrlError

__all__ = ["MQTTS_PORT", "MQTT_PORT", "Broker", "connect", "refused_mqtt5"]

MQTT_PORT = 1883  # the broker's port when the URL names none (plain, and TLS)
MQTTS_PORT = 8883
MAX_PACKET_BYTES = 268_435_455  # the largest packet MQTT can frame (its length's 4 bytes)
UNSUPPORTED_PROTOCOL_VERSION = 132  # MQTT 5's CONNACK reason code (a 3.1.1 broker's "1")


@dataclass(frozen=True, slots=True)
class Broker:
    """Where a broker is and how to log in to it.

    Attributes:
        host, port: its address.
        tls: whether to speak TLS (``mqtts://``).
        username, password: the login, or None.
        ca_file, cert_file, key_file: the authority to trust (None: the system's) and this
            client's certificate and key for TLS, or None.
    """

    host: str
    port: int
    tls: bool = False
    username: str | None = None
    password: str | None = None
    ca_file: str | None = None
    cert_file: str | None = None
    key_file: str | None = None

    @classmethod
    def of_url(
        cls,
        url: str,
        *,
        username: str | None = None,
        password: str | None = None,
        ca_file: str | None = None,
        cert_file: str | None = None,
        key_file: str | None = None,
    ) -> Broker:
        """The broker ``url`` names; a login given here wins over the URL's.

        Raises:
            BrokerUrlError: the URL is not ``mqtt://HOST[:PORT]`` or ``mqtts://HOST[:PORT]``.
        """
        try:
            parts = split_broker_url(url)
        except ValueError as err:
            raise BrokerUrlError(str(err)) from err
        port = parts.port
        tls = parts.scheme == "mqtts"
        return cls(
            host=str(parts.hostname),  # (split_broker_url checked there is one)
            port=port or (MQTTS_PORT if tls else MQTT_PORT),
            tls=tls,
            username=username if username is not None else parts.username,
            password=password if password is not None else parts.password,
            ca_file=ca_file,
            cert_file=cert_file,
            key_file=key_file,
        )


def connect(
    broker: Broker,
    identifier: str,
    *,
    will: aiomqtt.Will | None = None,
    keepalive_s: int = 60,
    max_packet_bytes: int | None = None,
) -> aiomqtt.Client:
    """A client for ``broker`` (not yet connected: ``async with`` it), known to the broker
    as ``identifier``, with its last ``will`` and a keep-alive of ``keepalive_s`` [s].

    With ``max_packet_bytes`` it speaks MQTT 5 and asks the broker to send no packet larger
    than that [bytes] (at most ``MAX_PACKET_BYTES``); without, MQTT 3.1.1."""
    tls = (
        aiomqtt.TLSParameters(
            ca_certs=broker.ca_file,
            certfile=broker.cert_file,
            keyfile=broker.key_file,
            cert_reqs=ssl.CERT_REQUIRED,
        )
        if broker.tls
        else None
    )
    properties = _largest_packet(max_packet_bytes)
    return aiomqtt.Client(
        broker.host,
        broker.port,
        identifier=identifier,
        username=broker.username,
        password=broker.password,
        tls_params=tls,
        will=will,
        keepalive=keepalive_s,
        protocol=None if properties is None else aiomqtt.ProtocolVersion.V5,
        properties=properties,
    )


def _largest_packet(max_packet_bytes: int | None) -> Properties | None:
    """MQTT 5's connect properties asking for packets of at most ``max_packet_bytes``."""
    if max_packet_bytes is None:
        return None
    properties = Properties(PacketTypes.CONNECT)  # type: ignore[no-untyped-call]
    properties.MaximumPacketSize = min(max_packet_bytes, MAX_PACKET_BYTES)
    return properties


def refused_mqtt5(err: aiomqtt.MqttError) -> bool:
    """Whether ``err`` is a broker's refusal of MQTT 5 (it speaks 3.1.1 or older)."""
    code = getattr(err, "rc", None)
    return code is not None and int(getattr(code, "value", code)) == UNSUPPORTED_PROTOCOL_VERSION
