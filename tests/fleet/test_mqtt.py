"""The vehicle's MQTT connection on a real mosquitto: in MQTT 5 it names the largest packet it
takes and the broker drops a larger message unsent, while smaller ones still come, in order;
a broker that speaks only 3.1.1 refuses MQTT 5 in a way ``refused_mqtt5`` knows, and takes
the same client in 3.1.1."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from navd.fleet.mqtt import Broker as Address
from navd.fleet.mqtt import connect, refused_mqtt5
from tests.fleet.broker import Broker
from tests.fleet.mqtt311_gate import Mqtt311Gate

aiomqtt = pytest.importorskip("aiomqtt", reason="aiomqtt missing")


async def _heard_after(port: int, listener: aiomqtt.Client, payloads: list[bytes]) -> list[int]:
    """The sizes ``listener`` hears of ``payloads`` sent in order by a 3.1.1 client, up to
    the last (a short one)."""
    await listener.subscribe("t/#", qos=1)
    async with aiomqtt.Client("127.0.0.1", port, identifier="sender") as sender:
        for payload in payloads:
            await sender.publish("t/x", payload, qos=1)
    sizes: list[int] = []
    async with asyncio.timeout(20.0):
        async for message in listener.messages:
            assert isinstance(message.payload, bytes)
            sizes.append(len(message.payload))
            if message.payload == payloads[-1]:
                return sizes
    return sizes


async def test_an_mqtt5_broker_drops_a_message_over_the_largest_packet_unsent(
    tmp_path: Path,
) -> None:
    broker = Broker(tmp_path)
    broker.start()
    try:
        address = Address("127.0.0.1", broker.port)
        async with connect(address, "vehicle", max_packet_bytes=65_536) as listener:
            sizes = await _heard_after(
                broker.port, listener, [b"a" * 10_000, b"b" * 200_000, b"c" * 60_000, b"end"]
            )
        assert sizes == [10_000, 60_000, 3]
        async with connect(address, "vehicle-311") as listener:  # 3.1.1: everything comes
            sizes = await _heard_after(broker.port, listener, [b"b" * 200_000, b"end"])
        assert sizes == [200_000, 3]
    finally:
        broker.stop()


async def test_a_broker_of_mqtt_3_1_1_refuses_5_recognizably_and_takes_3_1_1(
    tmp_path: Path,
) -> None:
    broker = Broker(tmp_path)
    broker.start()
    gate = Mqtt311Gate(broker.port)
    gate.start()
    try:
        address = Address("127.0.0.1", gate.port)
        with pytest.raises(aiomqtt.MqttError) as refused:
            async with connect(address, "vehicle", max_packet_bytes=65_536):
                pass
        assert refused_mqtt5(refused.value), str(refused.value)
        async with connect(address, "vehicle") as listener:
            sizes = await _heard_after(broker.port, listener, [b"b" * 200_000, b"end"])
        assert sizes == [200_000, 3]
        assert (gate.refused, gate.passed) == (1, 1)
    finally:
        gate.stop()
        broker.stop()


def test_other_refusals_are_not_taken_for_mqtt5s() -> None:
    assert not refused_mqtt5(aiomqtt.MqttCodeError(5, "not authorized"))  # 3.1.1's code 5
    assert not refused_mqtt5(aiomqtt.MqttError("connection lost"))
