"""The safety gate: the one place every wheel command passes, and the planner cannot bypass.

Modules request motion with VelocityCommand; only the gate publishes DriveCommand, the only
message the chassis obeys. The gate holds the robot still (zero DriveCommand) while any
reason holds: a sensor the estimate depends on that is stale or disconnected after having
been seen (see ``SafetyGate``), a SafeStop (a faulted module, lost localization) not yet
cleared by its key, or an operator's EmergencyStop until one releases it. It clamps what it
passes to the robot's speed limits, then lets its limiters (the collision guard) reduce it,
again at every scan while the command stands. The chassis driver adds the last guard: with
no fresh request for ``safety.reaction_timeout_s`` (a DriveCommand's stamp is its request's)
it writes zero itself. A triggered bumper or cliff sensor stops the robot at once and then
lets through only motion that backs away from it (``contact_holds``); a bumper or cliff
sensor that falls silent or leaves holds the robot like a lidar.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from navd.lifecycle.contact_holds import ContactHolds, contact_mounts
from navd.lifecycle.daemon_settings import gate_limits
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
from navd.lifecycle.module import Module, ModuleContext

__all__ = ["ESTOP_KEY", "ESTOP_REASON", "SafetyGate", "SpeedLimiter"]


class SpeedLimiter(Protocol):
    """Something the gate asks about every command (the collision guard)."""

    def limit(self, linear_mps: float, angular_radps: float) -> tuple[float, float, str]:
        """The command, possibly reduced, and why ("" when untouched)."""


# Kinds whose silence or loss holds the robot whenever one was there: the lidar sees the
# obstacles and localizes; the IMU's rates feed every pose.
ESSENTIAL = frozenset({DeviceKind.LIDAR, DeviceKind.IMU, DeviceKind.CONTACT})
# Kinds that hold the robot only while no lidar is there (then they are what localizes it).
WITHOUT_LIDAR = frozenset({DeviceKind.GPS, DeviceKind.WHEEL_ODOMETRY, DeviceKind.BEACON})
# Device holds listed one by one in the reasons; more are summed up (a bounded status frame).
MAX_LISTED_DEVICES = 8
ESTOP_KEY = "estop"  # the safe stop an operator's emergency stop holds
ESTOP_REASON = "emergency stop by"  # its reason: then who


@dataclass(frozen=True, slots=True)
class _DeviceHold:
    """A device that holds the robot still.

    Attributes:
        kind: what it was.
        since_s: [s] daemon time it fell silent or left.
        left: it disconnected (a silent one is still connected).
        why: the reason as the status shows it.
    """

    kind: DeviceKind
    since_s: float
    left: bool
    why: str


class SafetyGate(Module):
    """Turns requested VelocityCommands into DriveCommands, or zero while unsafe.

    Device rules: a lidar or an IMU that falls silent or leaves holds the robot until it is
    back, or, once it has left, until as many of its kind speak as ever did at once (the
    same sensor restarted under a new id, on a robot with one; on a robot with two, a
    second one connecting does not stand in for the first); a GPS, wheel odometry or beacon
    sensor does so
    only while no lidar is there. A device still connected but silent holds the robot until
    it speaks or leaves. One that never spoke since its hello while another of its kind
    speaks (a stray program, a second driver started on the wrong port) is mute: it holds
    nothing, counts for nothing, and is forgotten when it leaves; alone, it holds the robot
    like any silent one.
    """

    def __init__(self, limiters: Sequence[SpeedLimiter] = ()) -> None:
        super().__init__("safety")
        self._reasons: dict[str, str] = {}  # SafeStop holds, by key
        self._fresh: dict[str, DeviceKind] = {}  # devices connected and speaking
        self._most: dict[DeviceKind, int] = {}  # the most of each kind that spoke at once
        self._mute: set[str] = set()  # connected, never spoke, while others of its kind do
        self._device_holds: dict[str, _DeviceHold] = {}  # by device id
        self._contacts = ContactHolds()  # triggered bumpers and cliff sensors
        self._limiters = tuple(limiters)
        self._request: VelocityCommand | None = None  # the last command asked for
        self._driven = (0.0, 0.0)  # [m/s, rad/s] what the gate last let through

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(gate_limits)
        self.contact_mounts = ctx.settings(contact_mounts)
        ctx.subscribe(VelocityCommand, self._on_velocity)
        ctx.subscribe(LaserScan, self._on_scan)
        ctx.subscribe(DeviceStale, self._on_gone)
        ctx.subscribe(DeviceLost, self._on_gone)
        ctx.subscribe(DeviceResumed, self._on_back)
        ctx.subscribe(DeviceConnected, self._on_back)
        ctx.subscribe(Contact, self._on_contact)
        ctx.subscribe(SafeStop, self._on_safe_stop)
        ctx.subscribe(SafeStopCleared, self._on_cleared)
        ctx.subscribe(EmergencyStop, self._on_emergency_stop)

    def settings_in_use(self) -> tuple[object, ...]:
        return (self.settings.value, self.contact_mounts.value)

    @property
    def reasons(self) -> tuple[str, ...]:
        """Why the robot is held still: stops in the order they arose, then the devices."""
        devices = [hold.why for hold in self._device_holds.values()]
        if len(devices) > MAX_LISTED_DEVICES:
            more = len(devices) - MAX_LISTED_DEVICES
            devices = [*devices[:MAX_LISTED_DEVICES], f"and {more} more devices gone"]
        return (*self._reasons.values(), *self._contacts.reasons(), *devices)

    @property
    def held(self) -> bool:
        """True while any reason holds the robot still."""
        return bool(self._reasons or self._device_holds)

    # --- commands ---------------------------------------------------------------------------

    def _on_velocity(self, cmd: VelocityCommand) -> None:
        self._request = cmd
        if self.held:
            self._drive(0.0, 0.0, "; ".join(self.reasons), cmd.stamp)
            return
        linear, angular, why = self._limit(cmd)
        contacts = self._contacts
        if contacts.active and not contacts.allows(linear, angular, self.contact_mounts.value):
            reasons = "; ".join(contacts.reasons())
            self._drive(0.0, 0.0, f"{reasons}: only backing away", cmd.stamp)
            return
        self._drive(linear, angular, why, cmd.stamp)

    def _on_scan(self, _scan: LaserScan) -> None:
        """A new scan sweeps the command in force again: an obstacle that came into its path
        cuts it now, not at the next request (the chassis repeats it meanwhile). It keeps
        its request's stamp, so the chassis still stops when requests stop coming."""
        cmd = self._request
        if cmd is None or self.held or self._driven == (0.0, 0.0):
            return
        linear, angular, why = self._limit(cmd)
        if abs(linear) < abs(self._driven[0]) or abs(angular) < abs(self._driven[1]):
            self._drive(linear, angular, why, cmd.stamp)

    def _limit(self, cmd: VelocityCommand) -> tuple[float, float, str]:
        """The command clamped to the robot's limits, then reduced by each limiter."""
        limits = self.settings.value
        linear = min(max(cmd.linear_mps, -limits.max_reverse_mps), limits.max_forward_mps)
        yaw_limit = limits.max_yaw_rate_radps
        angular = min(max(cmd.angular_radps, -yaw_limit), yaw_limit)
        clamped = (linear, angular) != (cmd.linear_mps, cmd.angular_radps)
        reasons = ["clamped to robot limits"] if clamped else []
        for limiter in self._limiters:
            linear, angular, why = limiter.limit(linear, angular)
            if why:
                reasons.append(why)
        return linear, angular, "; ".join(reasons)

    # --- devices ----------------------------------------------------------------------------

    def _on_gone(self, msg: DeviceStale | DeviceLost) -> None:
        self._fresh.pop(msg.device_id, None)
        holds = msg.kind in ESSENTIAL or (msg.kind in WITHOUT_LIDAR and not self._has_lidar())
        if not holds or self._is_mute(msg):
            return
        what = (
            f"silent for more than {msg.silent_s:.2f} s"  # true for as long as the hold lasts
            if isinstance(msg, DeviceStale)
            else f"lost: {msg.reason}"
        )
        fresh = msg.device_id not in self._device_holds
        why = f"{msg.kind.value} {msg.device_id!r} {what}"
        left = isinstance(msg, DeviceLost)
        self._device_holds[msg.device_id] = _DeviceHold(msg.kind, msg.stamp, left, why)
        if fresh:
            self._held_now(why)

    def _is_mute(self, msg: DeviceStale | DeviceLost) -> bool:
        """Whether ``msg`` is of a device that never spoke while others of its kind speak (it
        is then mute, or forgotten if it left), taking back its count in ``_most``."""
        if isinstance(msg, DeviceLost) and msg.device_id in self._mute:
            self._mute.discard(msg.device_id)
            return True
        speaking = sum(1 for k in self._fresh.values() if k is msg.kind)
        if msg.spoke or speaking == 0:
            return False
        if isinstance(msg, DeviceStale):
            self._mute.add(msg.device_id)
        self._most[msg.kind] = max(self._most.get(msg.kind, 0) - 1, speaking)
        self.ctx.log.warning(
            "device_mute", device_id=msg.device_id, kind=msg.kind.value,
            note="never spoke since its hello while another of its kind speaks: ignored",
        )  # fmt: skip
        return True

    def _on_back(self, msg: DeviceResumed | DeviceConnected) -> None:
        kind = msg.kind
        if kind not in ESSENTIAL | WITHOUT_LIDAR:
            return
        self._mute.discard(msg.device_id)
        self._fresh[msg.device_id] = kind
        speaking = sum(1 for k in self._fresh.values() if k is kind)
        self._most[kind] = max(self._most.get(kind, 0), speaking)
        own = self._device_holds.get(msg.device_id)
        released = [msg.device_id] if own is not None and own.kind is kind else []
        if speaking >= self._most[kind]:
            # as many of its kind speak as ever did at once: those that left were replaced
            # (a sensor program restarted under a new id), not lost beside the others
            released += [d for d, h in self._device_holds.items() if h.left and h.kind is kind]
        if kind is DeviceKind.LIDAR:  # what stood in for a missing lidar matters no more
            released += [d for d, h in self._device_holds.items() if h.kind in WITHOUT_LIDAR]
        changed = [d for d in dict.fromkeys(released) if self._device_holds.pop(d, None)]
        if changed:
            self.ctx.log.info("safety_release", devices=changed, remaining=self.reasons)
            self._publish_state()

    def _has_lidar(self) -> bool:
        return DeviceKind.LIDAR in self._fresh.values()

    def _on_contact(self, contact: Contact) -> None:
        was = self._contacts.active
        if self._contacts.take(contact):
            self._held_now("; ".join(self._contacts.reasons()))
        elif was and not self._contacts.active:
            self.ctx.log.info("safety_release", contact=contact.sensor, remaining=self.reasons)
            self._publish_state()

    # --- stops ------------------------------------------------------------------------------

    def _on_safe_stop(self, msg: SafeStop) -> None:
        fresh = msg.key not in self._reasons
        self._reasons[msg.key] = msg.reason
        if fresh:
            self._held_now(msg.reason)

    def _on_emergency_stop(self, msg: EmergencyStop) -> None:
        """Held, as any safe stop, under ESTOP_KEY until released; either said once."""
        t = msg.stamp
        if msg.engaged:
            why = f"{ESTOP_REASON} {msg.source}"
            self._on_safe_stop(
                SafeStop(stamp=t, received=t, reason=why, source=msg.source, key=ESTOP_KEY)
            )
        else:
            self._on_cleared(SafeStopCleared(stamp=t, received=t, key=ESTOP_KEY, source=msg.source))

    def _on_cleared(self, msg: SafeStopCleared) -> None:
        if self._reasons.pop(msg.key, None) is not None:
            self.ctx.log.info("safety_release", reason=msg.key, remaining=self.reasons)
            self._publish_state()

    def _held_now(self, text: str) -> None:
        self.ctx.log.warning("safety_hold", reason=text)
        self._drive(0.0, 0.0, text, self.ctx.clock.now())
        self._publish_state()

    def _drive(self, linear: float, angular: float, reason: str, stamp: float) -> None:
        self._driven = (linear, angular)
        now = self.ctx.clock.now()
        self.ctx.publish(
            DriveCommand(
                stamp=stamp, received=now, linear_mps=linear, angular_radps=angular, reason=reason
            )
        )

    def _publish_state(self) -> None:
        now = self.ctx.clock.now()
        self.ctx.publish(SafetyState(stamp=now, received=now, reasons=self.reasons))
