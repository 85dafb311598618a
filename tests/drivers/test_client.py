"""navd's blocking client against a daemon on a real socket (run in a thread beside it)."""

from __future__ import annotations

import asyncio

import pytest

from navd.drivers.client import Client, ClientError, RequestRefusedError
from navd.drivers.protocol.frames import GoalFrame, SaveMapFrame, SubscribeFrame
from navd.drivers.protocol.replies import Ack, GoalStatusFrame, StatusFrame
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
