from __future__ import annotations

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.lifecycle.bus import Bus
from navd.lifecycle.messages import (
    Contact,
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DeviceResumed,
    DeviceStale,
    DriveCommand,
    EmergencyStop,
    LaserScan,
    SafeStop,
    SafeStopCleared,
    SafetyState,
    VelocityCommand,
)
from navd.lifecycle.module import ModuleContext
from navd.lifecycle.safety import MAX_LISTED_DEVICES, SafetyGate
from navd.lifecycle.workers import WorkerPool
from tests.conftest import velocity


def scan_message(t: float) -> LaserScan:
    """A small scan stamped at ``t`` (what the gate sweeps again with)."""
    ranges = np.full(8, 2.0, dtype=np.float32)
    return LaserScan(
        stamp=t,
        received=t,
        device_id="lidar0",
        angle_min=-1.0,
        angle_increment=0.25,
        ranges=ranges,
        range_min=0.1,
        range_max=10.0,
    )


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


def _device(cls: type, kind: DeviceKind, device_id: str, t: float = 0.0, **extra: object):  # type: ignore[no-untyped-def]
    return cls(stamp=t, received=t, device_id=device_id, kind=kind, **extra)


async def test_a_lost_imu_stops_until_it_is_back(bus: Bus, gate: SafetyGate) -> None:
    drives = _drives(bus)
    bus.publish(_device(DeviceConnected, DeviceKind.IMU, "imu0"))
    bus.publish(_device(DeviceLost, DeviceKind.IMU, "imu0", reason="unplugged"))
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop and "imu 'imu0' lost: unplugged" in drives[-1].reason
    bus.publish(_device(DeviceConnected, DeviceKind.IMU, "imu0", t=1.0))
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3


async def test_a_lidar_restarted_under_a_new_id_releases_the_old_ones_hold(
    bus: Bus, gate: SafetyGate
) -> None:
    drives = _drives(bus)
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "lidar-1"))
    bus.publish(_device(DeviceLost, DeviceKind.LIDAR, "lidar-1", t=1.0, reason="crashed"))
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "lidar-2", t=2.0))
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3
    assert gate.reasons == ()


async def test_a_lidar_that_never_spoke_beside_a_speaking_one_holds_nothing(
    bus: Bus, gate: SafetyGate
) -> None:
    drives = _drives(bus)
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "lidar0"))
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "rogue", t=1.0))
    bus.publish(_device(DeviceStale, DeviceKind.LIDAR, "rogue", t=1.2, silent_s=0.2, spoke=False))
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3, "a mute lidar beside a speaking one holds nothing"
    bus.publish(_device(DeviceLost, DeviceKind.LIDAR, "rogue", t=5.0, reason="closed", spoke=False))
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3 and gate.reasons == (), "and is forgotten when it leaves"
    # the real lidar's own loss still holds, and its restart under a new id releases it
    bus.publish(_device(DeviceLost, DeviceKind.LIDAR, "lidar0", t=6.0, reason="crashed"))
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "lidar1", t=7.0))
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3


async def test_a_lidar_that_never_spoke_alone_holds_the_robot(bus: Bus, gate: SafetyGate) -> None:
    drives = _drives(bus)
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "lidar0"))
    bus.publish(_device(DeviceStale, DeviceKind.LIDAR, "lidar0", t=0.2, silent_s=0.2, spoke=False))
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop and "lidar 'lidar0' silent" in drives[-1].reason


async def test_a_second_lidar_already_there_does_not_release_a_lost_one(
    bus: Bus, gate: SafetyGate
) -> None:
    drives = _drives(bus)
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "front"))
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "rear"))
    bus.publish(_device(DeviceStale, DeviceKind.LIDAR, "front", t=1.0, silent_s=0.3))
    bus.publish(_device(DeviceResumed, DeviceKind.LIDAR, "rear", t=1.5))
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop and "lidar 'front' silent" in drives[-1].reason
    # nor does one connecting anew: the silent one is still connected, not restarted
    bus.publish(_device(DeviceLost, DeviceKind.LIDAR, "rear", t=2.0, reason="blip"))
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "rear", t=2.5))
    assert [r for r in gate.reasons if "front" in r]


async def test_on_a_robot_with_two_lidars_one_back_does_not_stand_in_for_the_other(
    bus: Bus, gate: SafetyGate
) -> None:
    drives = _drives(bus)
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "front"))
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "rear"))
    bus.publish(_device(DeviceLost, DeviceKind.LIDAR, "front", t=1.0, reason="unplugged"))
    bus.publish(_device(DeviceLost, DeviceKind.LIDAR, "rear", t=1.5, reason="a blip"))
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "rear", t=2.0))  # back, alone
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop and "lidar 'front' lost: unplugged" in drives[-1].reason
    # the front one's program restarted under a new id: two speak again
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "front-2", t=3.0))
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3


async def test_a_hold_is_released_only_by_its_own_kind(bus: Bus, gate: SafetyGate) -> None:
    bus.publish(_device(DeviceConnected, DeviceKind.IMU, "imu0"))
    bus.publish(_device(DeviceLost, DeviceKind.IMU, "imu0", t=1.0, reason="gone"))
    bus.publish(_device(DeviceConnected, DeviceKind.GPS, "imu0", t=2.0))  # the id, not an IMU
    assert gate.reasons == ("imu 'imu0' lost: gone",)


async def test_gps_and_wheels_hold_only_while_no_lidar_is_there(bus: Bus, gate: SafetyGate) -> None:
    drives = _drives(bus)
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "lidar0"))
    bus.publish(_device(DeviceStale, DeviceKind.GPS, "gps0", silent_s=5.0))
    bus.publish(_device(DeviceStale, DeviceKind.COMPASS, "compass0", silent_s=5.0))
    bus.publish(velocity(0.3))
    assert [d.linear_mps for d in drives] == [0.3]
    # an outdoor robot with no lidar: its GPS and wheels are what localize it
    bus.publish(_device(DeviceLost, DeviceKind.LIDAR, "lidar0", t=1.0, reason="unplugged"))
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "lidar9", t=2.0))  # a restart
    bus.publish(_device(DeviceLost, DeviceKind.LIDAR, "lidar9", t=3.0, reason="unplugged"))
    bus.publish(_device(DeviceConnected, DeviceKind.LIDAR, "lidar8", t=4.0))
    assert gate.reasons == ()
    bus.publish(_device(DeviceLost, DeviceKind.LIDAR, "lidar8", t=5.0, reason="gone"))
    bus.publish(_device(DeviceConnected, DeviceKind.GPS, "gps1", t=5.0))
    bus.publish(_device(DeviceStale, DeviceKind.GPS, "gps1", t=6.0, silent_s=2.0))
    assert any("gps 'gps1' silent" in r for r in gate.reasons)
    bus.publish(_device(DeviceResumed, DeviceKind.GPS, "gps1", t=7.0))
    bus.publish(_device(DeviceStale, DeviceKind.WHEEL_ODOMETRY, "wheels", t=8.0, silent_s=1.0))
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop and "wheel_odometry 'wheels'" in drives[-1].reason


async def test_many_vanished_devices_give_a_bounded_reason_list(bus: Bus, gate: SafetyGate) -> None:
    for i in range(20_000):
        bus.publish(_device(DeviceLost, DeviceKind.IMU, f"ghost{i}", reason="gone"))
    reasons = gate.reasons
    assert len(reasons) == MAX_LISTED_DEVICES + 1
    assert reasons[-1] == f"and {20_000 - MAX_LISTED_DEVICES} more devices gone"
    bus.publish(_device(DeviceConnected, DeviceKind.IMU, "imu-new", t=1.0))
    assert gate.reasons == ()  # an IMU came after them all: they were one sensor restarting


class _Wall:
    """A limiter that stops the robot once ``blocked`` is set (an obstacle came)."""

    blocked = False

    def limit(self, linear: float, angular: float) -> tuple[float, float, str]:
        return (0.0, angular, "obstacle ahead") if self.blocked else (linear, angular, "")


async def test_each_scan_sweeps_the_command_in_force_again(bus: Bus) -> None:
    wall = _Wall()
    gate = SafetyGate([wall])
    config = NavdConfig()
    ctx = ModuleContext(
        "safety", bus=bus, clock=bus.clock, workers=WorkerPool(bus, 1), config=lambda: config
    )
    await gate.on_configure(ctx)
    drives = _drives(bus)
    bus.publish(velocity(0.3, t=4.0))
    assert drives[-1].linear_mps == 0.3
    bus.publish(scan_message(t=4.1))
    assert len(drives) == 1  # nothing changed: the command stands as it was sent
    wall.blocked = True
    bus.publish(scan_message(t=4.2))
    assert (drives[-1].linear_mps, drives[-1].reason) == (0.0, "obstacle ahead")
    # the cut keeps its request's stamp: the chassis still stops when requests stop coming
    assert drives[-1].stamp == 4.0


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


def _contact(sensor: str, kind: str, triggered: bool, t: float = 0.0) -> Contact:
    return Contact(
        stamp=t, received=t, device_id="mcu", sensor=sensor, kind=kind, triggered=triggered
    )  # type: ignore[arg-type]


@pytest.fixture
async def mounted_gate(bus: Bus) -> SafetyGate:
    """A gate on a robot with a front bumper, a front-left cliff sensor (0.2 m ahead, 0.1 m
    left) and nothing where "loose" would be."""
    gate = SafetyGate()
    config = NavdConfig.model_validate(
        {"mounts": {"contacts": {"front": {"x_m": 0.2}, "cliff_fl": {"x_m": 0.2, "y_m": 0.1}}}}
    )
    ctx = ModuleContext(
        "safety", bus=bus, clock=bus.clock, workers=WorkerPool(bus, 1), config=lambda: config
    )
    await gate.on_configure(ctx)
    return gate


async def test_a_bumper_stops_the_robot_at_once_and_lets_it_only_back_away(
    bus: Bus, mounted_gate: SafetyGate
) -> None:
    drives = _drives(bus)
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3
    bus.publish(_contact("front", "bumper", True))
    assert drives[-1].is_stop and "bumper 'front' pressed" in drives[-1].reason
    bus.publish(velocity(0.1))  # on into what it hit: no
    assert drives[-1].is_stop and "only backing away" in drives[-1].reason
    bus.publish(velocity(-0.1))  # back: yes
    assert drives[-1].linear_mps == -0.1
    bus.publish(velocity(0.0, 0.8))  # turning on the spot moves the front point sideways: yes
    assert drives[-1].angular_radps == 0.8
    bus.publish(_contact("front", "bumper", False, t=1.0))
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3


async def test_a_cliff_off_the_axis_forbids_the_turn_that_swings_it_out(
    bus: Bus, mounted_gate: SafetyGate
) -> None:
    drives = _drives(bus)
    bus.publish(_contact("cliff_fl", "cliff", True))
    assert "cliff 'cliff_fl' sees no floor" in drives[-1].reason
    # the sensor faces out through (0.2, 0.1): turning left swings it along (-0.1, 0.2),
    # square to its facing; backing up and right (v<0, w<0) takes it away
    bus.publish(velocity(-0.1, -0.5))
    assert drives[-1].linear_mps == -0.1
    bus.publish(velocity(0.05, 0.0))
    assert drives[-1].is_stop


async def test_a_contact_without_a_mount_holds_every_motion_until_released(
    bus: Bus, mounted_gate: SafetyGate
) -> None:
    drives = _drives(bus)
    bus.publish(_contact("loose", "bumper", True))
    bus.publish(velocity(-0.1))
    assert drives[-1].is_stop
    bus.publish(_contact("loose", "bumper", False, t=1.0))
    bus.publish(velocity(-0.1))
    assert drives[-1].linear_mps == -0.1


async def test_a_silent_contact_sensor_holds_the_robot(bus: Bus, gate: SafetyGate) -> None:
    drives = _drives(bus)
    bus.publish(_device(DeviceConnected, DeviceKind.CONTACT, "mcu"))
    bus.publish(_device(DeviceStale, DeviceKind.CONTACT, "mcu", silent_s=0.6))
    bus.publish(velocity(0.3))
    assert drives[-1].is_stop and "contact 'mcu' silent" in drives[-1].reason


async def test_an_emergency_stop_holds_every_motion_until_released(
    bus: Bus, gate: SafetyGate
) -> None:
    drives = _drives(bus)
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3
    bus.publish(EmergencyStop(stamp=1.0, received=1.0, engaged=True, source="ui"))
    assert drives[-1].is_stop and drives[-1].reason == "emergency stop by ui"  # at once
    bus.publish(velocity(-0.1))  # backing away too: nothing moves
    assert drives[-1].is_stop
    bus.publish(EmergencyStop(stamp=2.0, received=2.0, engaged=True, source="viewer-3"))
    assert len(gate.reasons) == 1  # one hold, whoever pressed again
    bus.publish(EmergencyStop(stamp=3.0, received=3.0, engaged=False, source="viewer-3"))
    bus.publish(velocity(0.3))
    assert drives[-1].linear_mps == 0.3
