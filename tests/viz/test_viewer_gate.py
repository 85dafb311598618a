"""The gate in front of the live view's server, on real sockets with the Foxglove SDK's real
server behind it: a cap on viewers, a deadline for the opening request, and a viewer that
stops reading let go before it costs more than its budget."""

from __future__ import annotations

import asyncio
import json
import shutil
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import pytest
import structlog
from foxglove import Context
from foxglove.channels import GridChannel
from foxglove.messages import Grid, PackedElementField, PackedElementFieldNumericType

from navd.viz import viewer_gate
from navd.viz.viewer_gate import GateLimits, ViewerGate, serve_viewers
from tests.viz.foxglove_client import FoxgloveClient, opening_request, stalled_viewer

MIB = 1_048_576


@asynccontextmanager
async def gate(limits: GateLimits) -> AsyncIterator[tuple[ViewerGate, GridChannel]]:
    context = Context()
    channel = GridChannel("/map", context=context)
    log = structlog.get_logger("test")
    server, served = await serve_viewers("127.0.0.1", 0, lambda: limits, log, context=context)
    try:
        yield served, channel
    finally:
        served.close()
        server.stop()


async def _raw(port: int) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    return await asyncio.open_connection("127.0.0.1", port)


async def test_one_viewer_too_many_is_answered_503_naming_the_setting() -> None:
    async with gate(GateLimits(max_viewers=2, buffer_bytes=8 * MIB)) as (served, _):
        viewers = [await FoxgloveClient.open(served.port) for _ in range(2)]
        try:
            reader, writer = await _raw(served.port)
            writer.write(opening_request())
            answer = await asyncio.wait_for(reader.read(), 10.0)  # read to the close
            assert answer.startswith(b"HTTP/1.1 503")
            assert b"viz.max_viewers" in answer
            writer.close()
            assert served.refused == 1
        finally:
            for viewer in viewers:
                await viewer.close()
        # one left: the next is let in
        await asyncio.wait_for(_until_fewer(served, 2), 10.0)
        again = await FoxgloveClient.open(served.port)
        await again.wait_for_topics({"/map"})
        await again.close()


async def _until_fewer(served: ViewerGate, n: int) -> None:
    while len(served.viewers) >= n:
        await asyncio.sleep(0.02)


async def test_an_opening_request_not_whole_in_time_is_cut_off(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(viewer_gate, "HANDSHAKE_DEADLINE_S", 0.5)
    async with gate(GateLimits(max_viewers=4, buffer_bytes=8 * MIB)) as (served, _):
        reader, writer = await _raw(served.port)
        writer.write(b"GET / HTTP/1.1\r\nHost: robot\r\n")  # and never the blank line
        began = asyncio.get_running_loop().time()
        assert await asyncio.wait_for(reader.read(), 10.0) == b""  # closed, nothing said
        assert asyncio.get_running_loop().time() - began >= 0.4
        assert served.viewers == set()
        writer.close()


async def test_a_viewer_that_stops_reading_is_let_go_at_its_budget() -> None:
    async with gate(GateLimits(max_viewers=4, buffer_bytes=MIB)) as (served, channel):
        reading = await FoxgloveClient.open(served.port)
        await reading.wait_for_topics({"/map"})
        await reading.subscribe("/map")
        stalled = await asyncio.to_thread(stalled_viewer, served.port, "/map")
        assert stalled is not None
        try:
            await asyncio.sleep(0.2)  # the subscription reaches the server
            for i in range(40):  # 0.5 MB frames: far past the budget for a viewer not reading
                channel.log(_grid(i))
                _, frame = await reading.receive("/map")  # the reading viewer keeps up
                assert frame.data[0] == i
            await asyncio.wait_for(_until_fewer(served, 2), 10.0)
            assert served.dropped == 1
            assert len(served.viewers) == 1  # the reader stays
        finally:
            stalled.close()
            await reading.close()


def _grid(i: int) -> Any:
    cells = bytes([i % 256]) + bytes(MIB // 2 - 1)  # under the test client's 1 MiB frames
    field = PackedElementField(name="v", offset=0, type=PackedElementFieldNumericType.Uint8)
    return Grid(
        frame_id="map",
        column_count=512,
        row_stride=512,
        cell_stride=1,
        fields=[field],
        data=cells,
    )


JS = Path(__file__).resolve().parents[1] / "js"


async def test_a_viewer_asking_for_foxglove_websocket_v1_is_served() -> None:
    node = shutil.which("node")
    if node is None or not (JS / "node_modules" / "@foxglove" / "ws-protocol").is_dir():
        pytest.skip(
            "node or @foxglove/ws-protocol is not installed (`make test` runs npm ci in "
            "tests/js where npm and its registry can be reached)"
        )
    async with gate(GateLimits(max_viewers=4, buffer_bytes=8 * MIB)) as (served, channel):
        viewer = await asyncio.create_subprocess_exec(
            node, str(JS / "foxglove_viewer.js"), f"ws://127.0.0.1:{served.port}", "/map", "3",
            cwd=JS, stdout=asyncio.subprocess.PIPE,
        )  # fmt: skip
        assert viewer.stdout is not None
        said: list[dict[str, Any]] = []

        async def hear() -> dict[str, Any]:
            assert viewer.stdout is not None
            said.append(json.loads(await asyncio.wait_for(viewer.stdout.readline(), 30.0)))
            return said[-1]

        try:
            while (await hear())["event"] != "advertise":
                pass
            await asyncio.sleep(0.3)  # its subscription reaches the server
            for i in range(3):
                channel.log(_grid(i))
            while sum(s["event"] == "message" for s in said) < 3:
                assert (await hear())["event"] == "message", said
        finally:
            if viewer.returncode is None:
                viewer.kill()
            await viewer.wait()
    assert said[0] == {"event": "open", "protocol": "foxglove.websocket.v1"}
    assert all(s["bytes"] > MIB // 2 for s in said if s["event"] == "message")
