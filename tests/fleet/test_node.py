"""The fleet module's state messages, on a stand-in for the broker client: the state goes out
when the robot starts and when it stops driving (VDA 5050 2.1 §6.10, "change in the driving
field"), not only when the order changes, and not again while nothing changed."""

from __future__ import annotations

import asyncio
import json
import time
import types
from typing import Any

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.fleet import node as fleet_node
from navd.fleet.node import FleetNode
from navd.lifecycle import Bus, ModuleContext, WorkerPool
from navd.lifecycle.messages import PoseEstimate, RobotState
from tests.fleet.vda5050_schemas import check


class _Client:
    """What the module publishes, as the fleet control would read it."""

    def __init__(self) -> None:
        self.sent: list[tuple[str, dict[str, Any]]] = []

    async def publish(self, topic: str, payload: bytes, qos: int = 0, retain: bool = False) -> None:
        self.sent.append((topic.rsplit("/", 1)[-1], json.loads(payload)))

    def states(self) -> list[dict[str, Any]]:
        return [body for topic, body in self.sent if topic == "state"]


def _pose(t: float, linear_mps: float) -> PoseEstimate:
    return PoseEstimate(
        stamp=t,
        received=t,
        x_m=1.0,
        y_m=2.0,
        yaw_rad=0.0,
        covariance=np.eye(3) * 1e-4,
        linear_mps=linear_mps,
    )


async def test_the_state_goes_out_when_the_robot_starts_and_when_it_stops(
    bus: Bus, monkeypatch: pytest.MonkeyPatch
) -> None:
    wall = [1000.0]  # [s] the module's clock for how often it publishes
    clock = types.SimpleNamespace(monotonic=lambda: wall[0], time=time.time)
    monkeypatch.setattr(fleet_node, "time", clock)
    config = NavdConfig.model_validate(
        {"fleet": {"enabled": True, "broker_url": "mqtt://127.0.0.1:1", "serial_number": "r1"}}
    )
    ctx = ModuleContext(
        "fleet", bus=bus, clock=bus.clock, workers=WorkerPool(bus, 1), config=lambda: config
    )
    module = FleetNode()
    await module.on_configure(ctx)
    client = _Client()
    module._client = client  # type: ignore[assignment]  # connected, as far as it knows

    async def tick(t: float, linear_mps: float) -> list[dict[str, Any]]:
        pose = _pose(t, linear_mps)
        bus.publish(RobotState(stamp=t, received=t, changed=frozenset({"pose"}), pose=pose))
        wall[0] += 1.0  # well past the least time between two states, far from 30 s
        module._tick(t)
        for _ in range(3):  # the sends are tasks of their own
            await asyncio.sleep(0)
        return client.states()

    assert [s["driving"] for s in await tick(0.0, 0.0)] == [False]  # the first: due at start
    assert len(await tick(1.0, 0.0)) == 1  # nothing changed: nothing sent
    assert [s["driving"] for s in await tick(2.0, 0.3)] == [False, True]  # it started
    assert len(await tick(3.0, 0.3)) == 2
    assert len(await tick(4.0, 0.0)) == 2  # slowed to standing: not yet still long enough
    assert [s["driving"] for s in await tick(4.6, 0.0)] == [False, True, False]  # it stopped
    assert len(await tick(5.0, 0.012)) == 3  # an estimate wandering while standing: no start
    for state in client.states():
        check("state", state)
        assert state["agvPosition"]["x"] == 1.0 and state["orderId"] == ""


async def test_the_position_goes_out_once_known_and_the_view_keeps_its_rate(
    bus: Bus, monkeypatch: pytest.MonkeyPatch
) -> None:
    wall = [1000.0]
    clock = types.SimpleNamespace(monotonic=lambda: wall[0], time=time.time)
    monkeypatch.setattr(fleet_node, "time", clock)
    config = NavdConfig.model_validate(
        {
            "fleet": {
                "enabled": True,
                "broker_url": "mqtt://127.0.0.1:1",
                "serial_number": "r1",
                "visualization_rate_hz": 2.0,
            }
        }
    )
    ctx = ModuleContext(
        "fleet", bus=bus, clock=bus.clock, workers=WorkerPool(bus, 1), config=lambda: config
    )
    module = FleetNode()
    await module.on_configure(ctx)
    client = _Client()
    module._client = client  # type: ignore[assignment]

    async def tick(t: float) -> None:
        wall[0] = 1000.0 + t
        module._tick(t)
        for _ in range(3):
            await asyncio.sleep(0)

    await tick(0.0)  # the first state, with no position yet
    assert "agvPosition" not in client.states()[-1]
    await tick(0.1)
    bus.publish(
        RobotState(stamp=1.1, received=1.1, changed=frozenset({"pose"}), pose=_pose(1.1, 0.0))
    )
    await tick(1.1)  # known: said at once, not at the next state_interval_s (30 s)
    assert client.states()[-1]["agvPosition"]["x"] == 1.0
    # 2 Hz on a clock that ticks every 0.1 s but a little late each time (0.103 s)
    for i in range(1, 200):
        await tick(1.1 + 0.103 * i)
    views = [body for topic, body in client.sent if topic == "visualization"]
    assert len(views) == pytest.approx(0.103 * 199 * 2.0, abs=2)  # 2 a second, not 1.7


async def test_a_message_over_the_size_cap_is_refused_unread(
    bus: Bus, monkeypatch: pytest.MonkeyPatch
) -> None:
    wall = [1000.0]
    clock = types.SimpleNamespace(monotonic=lambda: wall[0], time=time.time)
    monkeypatch.setattr(fleet_node, "time", clock)
    fleet = {"enabled": True, "broker_url": "mqtt://127.0.0.1:1", "serial_number": "r1"}
    config = NavdConfig.model_validate({"fleet": fleet | {"max_message_bytes": 65_536}})
    ctx = ModuleContext(
        "fleet", bus=bus, clock=bus.clock, workers=WorkerPool(bus, 1), config=lambda: config
    )
    module = FleetNode()
    await module.on_configure(ctx)
    client = _Client()
    module._client = client  # type: ignore[assignment]
    # not even JSON: had it been read, the error would be about its syntax
    said = []
    for topic, raw in (
        (module.topics.order, b"[" * 70_000),
        (module.topics.instant_actions, b"{" * 65_537),
    ):
        module._heard(topic, raw)
        wall[0] += 1.0
        module._tick(wall[0])
        for _ in range(3):
            await asyncio.sleep(0)
        check("state", client.states()[-1])
        said += [(e["errorType"], e["errorDescription"]) for e in client.states()[-1]["errors"]]
    assert said == [
        ("validationError", "order of 70000 bytes not read: over fleet.max_message_bytes (65536)"),
        (
            "validationError",
            "instantActions of 65537 bytes not read: over fleet.max_message_bytes (65536)",
        ),
    ]
    # another vehicle's position, padded past the cap: not taken, however well formed
    view = {"agvPosition": {"x": 1.0, "y": 2.0, "theta": 0.0, "mapId": "map"}, "pad": "x" * 70_000}
    module._heard("uagv/v2/navd/r2/visualization", json.dumps(view).encode())
    assert module._others.positions == {}
    view["pad"] = ""
    module._heard("uagv/v2/navd/r2/visualization", json.dumps(view).encode())
    assert list(module._others.positions) == ["navd/r2"]
