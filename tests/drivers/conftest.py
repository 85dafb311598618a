"""An in-process daemon with the real modules on a real TCP socket, and navd's own client."""

from __future__ import annotations

import asyncio
import tempfile
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Any

from navd.app import build_modules
from navd.config import parse_config
from navd.drivers.tcp.server import TcpServer
from navd.lifecycle import Daemon
from navd.lifecycle.messages import Message
from navd.wire import AsyncClient, Hello, Reply

READY_TIMEOUT_S = 30.0  # [s] start-up: imports and module activation
WARM_UP_TIMEOUT_S = 300.0  # [s] numba kernels compiling with a cold cache on a slow machine


@asynccontextmanager
async def running_daemon(
    before_start: Callable[[Daemon], object] | None = None, **sections: dict[str, Any]
) -> AsyncIterator[tuple[Daemon, int]]:
    """A started daemon listening on a free port; yields it and the port.

    ``before_start`` is given the daemon before it starts (to record what its start-up
    publishes)."""
    sections.setdefault("tcp", {})
    sections["tcp"] = {"port": 0, **sections["tcp"]}
    sections["viz"] = {"port": 0, "page_port": 0, **sections.get("viz", {})}
    # the level the tests' own logging runs at (a daemon applies its level when it starts)
    sections["logging"] = {"level": "warning", **sections.get("logging", {})}
    # maps go to a folder of the test's own unless it names one (the default, "maps", is
    # relative to where the suite runs: the repository)
    with tempfile.TemporaryDirectory(prefix="navd-test-maps-") as maps:
        sections["slam"] = {"map_dir": maps, **sections.get("slam", {})}
        config = parse_config(sections)
        daemon = Daemon(config, build_modules(config), handle_signals=False)
        if before_start is not None:
            before_start(daemon)
        task = asyncio.create_task(daemon.run())
        try:
            await asyncio.wait_for(daemon.ready.wait(), READY_TIMEOUT_S)
            # The kernels compile beside the loop after start-up; with a cold numba cache
            # that takes a while, and no test here is about it.
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


async def hello(
    port: int, role: str, device_id: str, token: str | None = None
) -> tuple[AsyncClient, Reply]:
    """A connection that said hello, and navd's first answer (a welcome or a fatal error)."""
    client = await AsyncClient.open("127.0.0.1", port)
    client.send(Hello(role=role, device_id=device_id, token=token))  # type: ignore[arg-type]
    return client, await client.receive(3.0)


async def connected(port: int, role: str, device_id: str) -> AsyncClient:
    """A welcomed connection."""
    return await AsyncClient.connect("127.0.0.1", port, role=role, device_id=device_id)


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
