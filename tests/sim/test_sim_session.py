"""Starting a session's daemon: a daemon that dies is reported at once, with its words."""

from __future__ import annotations

import asyncio
import sys
import time
from pathlib import Path

import pytest

from navd.sim import sim_session
from navd.sim.errors import SimError
from navd.sim.ports import free_port
from navd.wire import PROTOCOL_VERSION, Welcome


async def test_a_daemon_that_exits_while_starting_is_reported_with_its_log(
    tmp_path: Path,
) -> None:
    log_path = tmp_path / "navd.log"
    with log_path.open("wb") as log:
        dying = await asyncio.create_subprocess_exec(
            sys.executable,
            "-c",
            "import sys; print('config: no such map', flush=True); sys.exit(3)",
            stdout=log,
            stderr=log,
        )
        await dying.wait()
    began = time.monotonic()
    with pytest.raises(SimError) as raised:
        await sim_session._welcomed_control(free_port(), dying, log_path)
    assert time.monotonic() - began < sim_session.READY_TIMEOUT_S / 2  # not its whole wait
    assert "code 3" in str(raised.value)
    assert "config: no such map" in str(raised.value)


async def test_a_daemon_slow_to_listen_is_waited_for(tmp_path: Path) -> None:
    """A port nobody listens on yet is tried again until a server is there."""
    port = free_port()
    log_path = tmp_path / "navd.log"
    log_path.write_text("")
    sleeper = await asyncio.create_subprocess_exec(
        sys.executable, "-c", "import time; time.sleep(600)"
    )
    welcomed = asyncio.Event()

    async def navd_like(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await reader.readline()  # the hello
        welcome = Welcome(
            protocol=PROTOCOL_VERSION,
            daemon="navd",
            device_id="sim-control",
            role="control",
            max_line_bytes=4096,
        )
        writer.write(welcome.model_dump_json().encode() + b"\n")
        await writer.drain()
        welcomed.set()

    attempt = asyncio.create_task(sim_session._welcomed_control(port, sleeper, log_path))
    try:
        await asyncio.sleep(1.0)  # several refused attempts first
        assert not attempt.done()
        server = await asyncio.start_server(navd_like, "127.0.0.1", port)
        async with server:
            client = await asyncio.wait_for(attempt, 30.0)
            assert welcomed.is_set()
            client.writer.close()
    finally:
        sleeper.kill()
        await sleeper.wait()
