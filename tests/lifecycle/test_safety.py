from __future__ import annotations

import pytest

from navd.config import NavdConfig
from navd.lifecycle.bus import Bus
from navd.lifecycle.messages import (
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DeviceResumed,
    DeviceStale,
    DriveCommand,
    SafeStop,
    SafeStopCleared,
    SafetyState,
    VelocityCommand,
)
from navd.lifecycle.module import ModuleContext
from navd.lifecycle.safety import SafetyGate
from navd.lifecycle.workers import WorkerPool
from tests.conftest import velocity


@pytest.fixture
async def gate(bus: Bus) -> SafetyGate:
    gate = SafetyGate()
    config = NavdConfig()
    ctx = ModuleContext(
        "safety", bus=bus, clock=bus.clock, workers=WorkerPool(bus, 1), config=lambda: config
    )
    await gate.on_configure(ctx)
    return gate


def _drives(bus: Bus) -> list[DriveCommand]:
    out: list[DriveCommand] = []
    bus.subscribe(DriveCommand, out.append, module="chassis")
    return out


def _lidar(cls: type, **extra: object) -> object:
    return cls(stamp=0, received=0, device_id="lidar0", kind=DeviceKind.LIDAR, **extra)


async def test_passes_commands_within_limits_and_clamps_the_rest(
    bus: Bus, gate: SafetyGate
) -> None:
    drives = _drives(bus)
    bus.publish(velocity(0.3, 0.5))
    bus.publish(velocity(2.0, -9.0))  # limits: 0.5 m/s, 1.5 rad/s
    bus.publish(velocity(-1.0, 0.0))  # reverse limit 0.2 m/s
    assert [(d.linear_mps, d.angular_radps, d.reason) for d in drives] == [
        (0.3, 0.5, ""),
        (0.5, -1.5, "clamped to robot limits"),
        (-0.2, 0.0, "clamped to robot limits"),
    ]


@pytest.mark.parametrize(
    ("loss", "back"),
    [
        (_lidar(DeviceStale, silent_s=0.7), _lidar(DeviceResumed)),
        (_lidar(DeviceLost, reason="unplugged"), _lidar(DeviceConnected)),
    ],
)
async def test_lidar_loss_stops_until_it_is_back(
    bus: Bus, gate: SafetyGate, loss: object, back: object
) -> None:
    drives = _drives(bus)
    states: list[SafetyState] = []
    bus.subscribe(SafetyState, states.append, module="ui")
    bus.publish(loss)  # type: ignore[arg-type]
    assert drives[-1].is_stop and "lidar 'lidar0'" in drives[-1].reason
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop
    bus.publish(back)  # type: ignore[arg-type]
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3
    assert [len(s.reasons) for s in states] == [1, 0]


async def test_other_devices_do_not_stop_the_robot(bus: Bus, gate: SafetyGate) -> None:
    drives = _drives(bus)
    bus.publish(
        DeviceStale(stamp=0, received=0, device_id="gps0", kind=DeviceKind.GPS, silent_s=5.0)
    )
    bus.publish(velocity(0.3))
    assert [d.linear_mps for d in drives] == [0.3]


async def test_safe_stop_holds_until_cleared_by_its_key(bus: Bus, gate: SafetyGate) -> None:
    drives = _drives(bus)
    bus.publish(SafeStop(stamp=0, received=0, reason="obstacle", source="guard", key="near"))
    bus.publish(SafeStop(stamp=0, received=0, reason="faulted", source="sup", key="fault:x"))
    bus.publish(SafeStopCleared(stamp=0, received=0, key="near", source="guard"))
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop and drives[-1].reason == "faulted"
    bus.publish(SafeStopCleared(stamp=0, received=0, key="fault:x", source="sup"))
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3
    assert gate.reasons == ()


async def test_a_supervisor_fault_stops_at_once(bus: Bus, gate: SafetyGate) -> None:
    drives = _drives(bus)

    def broken(cmd: VelocityCommand) -> None:
        if cmd.source == "test":
            raise RuntimeError("planner bug")

    bus.subscribe(VelocityCommand, broken, module="planner")
    for _ in range(3):  # the bus fixture faults a module after 3 failures
        bus.publish(velocity(0.3))
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop and "'planner' failed 3 times" in drives[-1].reason
