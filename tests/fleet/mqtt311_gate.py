"""A broker that speaks only MQTT 3.1.1, as older brokers and some cloud ones do: a gate in
front of a real mosquitto that answers an MQTT 5 CONNECT the way a 3.1.1 broker must (CONNACK
with return code 1, "unacceptable protocol level", then the connection closed; MQTT 3.1.1
§3.1.2.2) and passes every other connection through, byte for byte, in a thread of its own."""

from __future__ import annotations

import asyncio
import contextlib
import socket
import threading

__all__ = ["Mqtt311Gate"]

REFUSED_LEVEL = b"\x20\x02\x00\x01"  # CONNACK, no session, return code 1
MQTT5 = 5


class Mqtt311Gate:
    """Listens on 127.0.0.1:``port`` and forwards to the broker on ``upstream_port``."""

    def __init__(self, upstream_port: int) -> None:
        self.upstream_port = upstream_port
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            self.port = probe.getsockname()[1]
        self.refused = 0  # MQTT 5 connections turned away
        self.passed = 0
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self) -> None:
        self._thread.start()
        if not self._ready.wait(10.0):
            raise RuntimeError("the MQTT 3.1.1 gate did not start listening in 10 s")

    def stop(self) -> None:
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(10.0)

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        server = self._loop.run_until_complete(
            asyncio.start_server(self._serve, "127.0.0.1", self.port)
        )
        self._ready.set()
        self._loop.run_forever()
        server.close()
        passing = asyncio.all_tasks(self._loop)  # connections still open: ended here
        for task in passing:
            task.cancel()
        self._loop.run_until_complete(asyncio.gather(*passing, return_exceptions=True))
        self._loop.close()

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            head = await _connect_head(reader)
            if head[-1] == MQTT5:  # the protocol level, after the name "MQTT"
                self.refused += 1
                writer.write(REFUSED_LEVEL)
                await writer.drain()
                return
            self.passed += 1
            up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.upstream_port)
            up_writer.write(head)
            await asyncio.gather(_pipe(reader, up_writer), _pipe(up_reader, writer))
        except (OSError, asyncio.IncompleteReadError):
            pass
        finally:
            writer.close()


async def _connect_head(reader: asyncio.StreamReader) -> bytes:
    """The CONNECT packet's bytes up to and including its protocol level."""
    head = await reader.readexactly(1)  # the packet type
    while True:  # the remaining length, 7 bits a byte
        byte = await reader.readexactly(1)
        head += byte
        if not byte[0] & 0x80:
            break
    return head + await reader.readexactly(2 + 4 + 1)  # len("MQTT"), "MQTT", the level


async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    with contextlib.suppress(OSError):
        while data := await reader.read(65536):
            writer.write(data)
            await writer.drain()
    writer.close()
