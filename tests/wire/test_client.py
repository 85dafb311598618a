"""navd's blocking client against a daemon on a real socket (run in a thread beside it)."""

from __future__ import annotations

import asyncio

import pytest

from navd.wire import (
    Ack,
    AsyncClient,
    Client,
    ClientError,
    ConnectionClosedError,
    GoalFrame,
    GoalStatusFrame,
    RequestRefusedError,
    SaveMapFrame,
    StatusFrame,
    SubscribeFrame,
    Welcome,
    encode,
)
from tests.drivers.conftest import running_daemon


def _session(port: int) -> tuple[Ack, GoalStatusFrame, StatusFrame, str]:
    with Client("127.0.0.1", port, device_id="cli-test") as navd:
        ack = navd.request(GoalFrame(x=1.0, y=2.0, goal_id="g1"))
        progress = navd.receive_type(GoalStatusFrame)
        navd.request(SubscribeFrame(rate_hz=20))
        status = navd.receive_type(StatusFrame)  # goal progress in between is skipped
        with pytest.raises(RequestRefusedError) as refused:
            navd.request(SaveMapFrame.model_construct(name="../../etc/passwd"))
        return ack, progress, status, refused.value.error.field


async def test_requests_are_acknowledged_and_refusals_name_the_field() -> None:
    async with running_daemon() as (_, port):
        ack, progress, status, field = await asyncio.to_thread(_session, port)
    assert ack == Ack(request="goal", goal_id="g1")
    assert progress.goal_id == "g1"
    assert any(d.device_id == "cli-test" for d in status.devices)
    assert field == "name"


def test_a_daemon_that_is_not_there_is_a_clear_error() -> None:
    from tests.e2e.conftest import free_port

    with pytest.raises(ClientError, match=r"cannot reach navd at 127\.0\.0\.1:\d+"):
        Client("127.0.0.1", free_port(), timeout_s=1.0)


async def test_replies_of_a_kind_this_client_does_not_know_are_skipped() -> None:
    welcome = Welcome(protocol=1, daemon="navd 9", device_id="c", role="control", max_line_bytes=9)

    async def newer_navd(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await reader.readline()  # the hello
        writer.write(
            encode(welcome)
            + b'{"type":"map_tile","x":1}\n'  # a reply kind added after this client
            + encode(Ack(request="goal", goal_id="g"))
        )
        await writer.drain()
        writer.close()

    server = await asyncio.start_server(newer_navd, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    async with server:
        client = await AsyncClient.connect("127.0.0.1", port, device_id="c")
        assert client.welcome == welcome
        assert await client.receive() == Ack(request="goal", goal_id="g")
        with pytest.raises(ConnectionClosedError):
            await client.receive(2.0)
        await client.close()
