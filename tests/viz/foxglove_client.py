"""A Foxglove WebSocket protocol client for tests: connects like the Foxglove app does,
subscribes to topics and decodes what arrives with the schemas the server advertised."""

from __future__ import annotations

import asyncio
import base64
import functools
import json
import os
import re
import socket
import struct
from dataclasses import dataclass
from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.message import Message
from websockets.asyncio.client import ClientConnection, connect

SUBPROTOCOL = "foxglove.sdk.v1"  # the Foxglove WebSocket protocol, as the SDK names it
MESSAGE_DATA = 0x01  # binary opcode of a message on a subscription
CLIENT_MESSAGE_DATA = 0x01  # binary opcode of a message a client publishes on its channel


@dataclass(frozen=True)
class Channel:
    """A channel the server advertised."""

    id: int
    topic: str
    encoding: str
    schema_name: str
    schema: str
    schema_encoding: str


@functools.cache
def protobuf_class(schema_name: str, file_descriptor_set: bytes) -> type[Message]:
    """The protobuf message class of ``schema_name`` from a serialized FileDescriptorSet."""
    files = descriptor_pb2.FileDescriptorSet.FromString(file_descriptor_set)
    pool = descriptor_pool.DescriptorPool()
    for proto in files.file:  # dependencies come first in Foxglove's sets
        pool.Add(proto)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


class FoxgloveClient:
    """One connection to a live view."""

    def __init__(self, ws: ClientConnection) -> None:
        self.ws = ws
        self.channels: dict[str, Channel] = {}
        self._subscriptions: dict[int, Channel] = {}
        self.text: list[dict[str, Any]] = []
        self._advertised: dict[int, str] = {}

    @classmethod
    async def open(
        cls, port: int, timeout_s: float = 10.0, host: str = "127.0.0.1"
    ) -> FoxgloveClient:
        ws = await asyncio.wait_for(
            connect(f"ws://{host}:{port}", subprotocols=[SUBPROTOCOL]), timeout_s
        )
        return cls(ws)

    async def close(self) -> None:
        await self.ws.close()

    async def wait_for_topics(self, topics: set[str], timeout_s: float = 10.0) -> None:
        """Read until every topic in ``topics`` is advertised."""

        async def read() -> None:
            while not topics <= self.channels.keys():
                await self._read_one()

        await asyncio.wait_for(read(), timeout_s)

    async def subscribe(self, *topics: str) -> None:
        subscriptions = []
        for topic in topics:
            channel = self.channels[topic]
            sub_id = len(self._subscriptions) + 1
            self._subscriptions[sub_id] = channel
            subscriptions.append({"id": sub_id, "channelId": channel.id})
        await self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    async def unsubscribe(self, topic: str) -> None:
        """End our subscriptions to ``topic``."""
        ids = [i for i, c in self._subscriptions.items() if c.topic == topic]
        await self.ws.send(json.dumps({"op": "unsubscribe", "subscriptionIds": ids}))

    async def advertise(self, topic: str, schema_name: str = "") -> int:
        """Offer a channel of ours on ``topic`` (JSON), as a publishing panel does; its id."""
        channel_id = len(self._advertised) + 1
        self._advertised[channel_id] = topic
        channel = {"id": channel_id, "topic": topic, "encoding": "json", "schemaName": schema_name}
        await self.ws.send(json.dumps({"op": "advertise", "channels": [channel]}))
        return channel_id

    async def publish(self, channel_id: int, message: Any) -> None:
        """Send ``message`` (JSON-encoded unless already bytes) on our channel."""
        payload = message if isinstance(message, bytes) else json.dumps(message).encode()
        await self.ws.send(struct.pack("<BI", CLIENT_MESSAGE_DATA, channel_id) + payload)

    async def receive(self, topic: str, timeout_s: float = 10.0) -> tuple[int, Any]:
        """The next message on ``topic``: (log time [ns], decoded message: a protobuf message,
        or a dict for JSON channels)."""

        async def read() -> tuple[int, Any]:
            while True:
                got = await self._read_one()
                if got is not None and got[0].topic == topic:
                    return got[1], got[2]

        return await asyncio.wait_for(read(), timeout_s)

    async def receive_each(self, *topics: str, timeout_s: float = 10.0) -> dict[str, Any]:
        """The first message on each of ``topics``, in whatever order they come (the map is
        built in a worker, so it may come after states sent later): topic -> decoded."""

        async def read() -> dict[str, Any]:
            first: dict[str, Any] = {}
            while len(first) < len(topics):
                got = await self._read_one()
                if got is not None and got[0].topic in topics:
                    first.setdefault(got[0].topic, got[2])
            return first

        return await asyncio.wait_for(read(), timeout_s)

    async def receive_any(self, timeout_s: float = 10.0) -> tuple[str, int, Any]:
        """The next message on any subscribed topic: (topic, log time [ns], decoded)."""

        async def read() -> tuple[str, int, Any]:
            while True:
                got = await self._read_one()
                if got is not None:
                    return got[0].topic, got[1], got[2]

        return await asyncio.wait_for(read(), timeout_s)

    async def _read_one(self) -> tuple[Channel, int, Any] | None:
        frame = await self.ws.recv()
        if isinstance(frame, str):
            op = json.loads(frame)
            self.text.append(op)
            if op.get("op") == "advertise":
                for c in op["channels"]:
                    self.channels[c["topic"]] = Channel(
                        c["id"],
                        c["topic"],
                        c["encoding"],
                        c.get("schemaName", ""),
                        c.get("schema", ""),
                        c.get("schemaEncoding", ""),
                    )
            return None
        if frame[0] != MESSAGE_DATA:
            return None
        sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
        payload = frame[13:]
        channel = self._subscriptions[sub_id]
        if channel.encoding == "json":
            return channel, log_time, json.loads(payload)
        cls = protobuf_class(channel.schema_name, base64.b64decode(channel.schema))
        return channel, log_time, cls.FromString(payload)


def opening_request() -> bytes:
    """A WebSocket opening request for the Foxglove protocol, as a browser sends it."""
    key = base64.b64encode(os.urandom(16)).decode()
    return (
        "GET / HTTP/1.1\r\nHost: robot\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
        f"Sec-WebSocket-Protocol: {SUBPROTOCOL}\r\n\r\n"
    ).encode()


def stalled_viewer(port: int, topic: str, timeout_s: float = 10.0) -> socket.socket | None:
    """A viewer that opens, subscribes to ``topic`` and then never reads again (a browser
    tab frozen in the background); None if the server refused it (an HTTP answer that is
    not 101)."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=timeout_s)
    sock.sendall(opening_request())
    seen = b""
    pattern = re.compile(rb'"id":(\d+),"topic":"' + re.escape(topic.encode()) + rb'"')
    while (found := pattern.search(seen)) is None:
        data = sock.recv(65536)
        seen += data
        if not data or (seen.startswith(b"HTTP/") and not seen.startswith(b"HTTP/1.1 101")):
            sock.close()
            return None
    payload = b'{"op":"subscribe","subscriptions":[{"id":1,"channelId":%d}]}' % int(found.group(1))
    mask = os.urandom(4)
    masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
    sock.sendall(bytes([0x81, 0x80 | len(payload)]) + mask + masked)  # one masked text frame
    return sock
