"""The one way navd opens an MQTT connection: a broker named by its URL
(``mqtt://HOST[:PORT]`` or ``mqtts://HOST[:PORT]``, with user and password in the URL or
given apart, and client certificates for TLS), as an aiomqtt client.

The vehicle (``node.FleetNode``), the fleet control (``navd fleet``) and the fleet benchmark
connect through ``connect``; what they say on the connection is theirs.
"""

from __future__ import annotations

import ssl
from dataclasses import dataclass

import aiomqtt

from navd.config import split_broker_url
from navd.fleet.errors import BrokerUrlError

__all__ = ["MQTTS_PORT", "MQTT_PORT", "Broker", "connect"]

MQTT_PORT = 1883  # the broker's port when the URL names none (plain, and TLS)
MQTTS_PORT = 8883


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
) -> aiomqtt.Client:
    """A client for ``broker`` (not yet connected: ``async with`` it), known to the broker
    as ``identifier``, with its last ``will`` and a keep-alive of ``keepalive_s`` [s]."""
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
    return aiomqtt.Client(
        broker.host,
        broker.port,
        identifier=identifier,
        username=broker.username,
        password=broker.password,
        tls_params=tls,
        will=will,
        keepalive=keepalive_s,
    )
