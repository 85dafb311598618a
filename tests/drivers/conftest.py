"""An in-process daemon with the real modules on a real TCP socket, and an async client."""

from __future__ import annotations

import asyncio
import contextlib
import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from navd.app import build_modules
from navd.config import parse_config
from navd.drivers.tcp_server import TcpServer
from navd.lifecycle.daemon import Daemon
from navd.lifecycle.messages import Message

READY_TIMEOUT_S = 30.0  # [s] start-up: imports and module activation
WARM_UP_TIMEOUT_S = 300.0  # [s] numba kernels compiling with a cold cache on a slow machine


@asynccontextmanager
async def running_daemon(**sections: dict[str, Any]) -> AsyncIterator[tuple[Daemon, int]]:
    """A started daemon listening on a free port; yields it and the port."""
    sections.setdefault("tcp", {})
    sections["tcp"] = {"port": 0, **sections["tcp"]}
    config = parse_config(sections)
    daemon = Daemon(config, build_modules(config), handle_signals=False)
    task = asyncio.create_task(daemon.run())
    try:
        await asyncio.wait_for(daemon.ready.wait(), READY_TIMEOUT_S)
        # The kernels compile beside the loop after start-up; with a cold numba cache that
        # takes a while, and no test here is about it.
        await asyncio.wait_for(daemon.workers.wait_idle(), WARM_UP_TIMEOUT_S)
        server = next(m for m in daemon.manager.modules if isinstance(m, TcpServer))
        yield daemon, server.port
    finally:
        daemon.request_shutdown("test over")
        await asyncio.wait_for(task, 5.0)


def record(daemon: Daemon, message_type: type[Message]) -> list[Any]:
    """Every message of ``message_type`` published from now on."""
    seen: list[Any] = []
    daemon.bus.subscribe(message_type, seen.append, module="test-recorder")
    return seen


class AsyncClient:
    """A protocol client on asyncio streams (blocking sockets would stall the daemon's loop)."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader = reader
        self.writer = writer

    @classmethod
    async def open(cls, port: int) -> AsyncClient:
        reader, writer = await asyncio.open_connection("127.0.0.1", port, limit=1 << 22)
        return cls(reader, writer)

    @classmethod
    async def hello(
        cls, port: int, role: str, device_id: str, token: str | None = None
    ) -> tuple[AsyncClient, dict[str, Any]]:
        client = await cls.open(port)
        frame: dict[str, Any] = {
            "type": "hello",
            "protocol": 1,
            "role": role,
            "device_id": device_id,
        }
        if token is not None:
            frame["token"] = token
        await client.send(frame)
        return client, await client.recv()

    async def send(self, frame: dict[str, Any] | bytes) -> None:
        data = frame if isinstance(frame, bytes) else json.dumps(frame).encode()
        self.writer.write(data + b"\n")
        await self.writer.drain()

    async def recv(self, timeout_s: float = 3.0) -> dict[str, Any]:
        line = await asyncio.wait_for(self.reader.readline(), timeout_s)
        if not line:
            return {"type": "eof"}
        frame: dict[str, Any] = json.loads(line)
        return frame

    async def recv_type(self, frame_type: str, timeout_s: float = 3.0) -> dict[str, Any]:
        async def find() -> dict[str, Any]:
            while True:
                frame = await self.recv(timeout_s)
                if frame["type"] in (frame_type, "eof"):
                    return frame

        return await asyncio.wait_for(find(), timeout_s)

    async def close(self) -> None:
        self.writer.close()
        with contextlib.suppress(ConnectionError):
            await self.writer.wait_closed()


async def until(predicate: Any, timeout_s: float = 3.0) -> None:
    """Let the loop run until ``predicate()`` is true."""

    async def wait() -> None:
        while not predicate():
            await asyncio.sleep(0.005)

    await asyncio.wait_for(wait(), timeout_s)


def pytest_asyncio_loop_factories(config: Any, item: Any) -> dict[str, Any]:
    """Driver tests run on both event loops navd supports (lifecycle.event_loop)."""
    import uvloop

    return {"asyncio": asyncio.new_event_loop, "uvloop": uvloop.new_event_loop}
