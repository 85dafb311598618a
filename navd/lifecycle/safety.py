"""The safety gate: the one place every wheel command passes, and the planner cannot bypass.

Modules request motion with VelocityCommand; only the gate publishes DriveCommand, the only
message the chassis obeys. The gate holds the robot still (zero DriveCommand) while any
reason holds: a lidar that is stale or disconnected after having been seen, or a SafeStop
(a faulted module, later a close obstacle or lost localization) not yet cleared by its key.
It clamps what it passes to the robot's speed limits, then lets its limiters (the collision
guard) reduce it. The chassis driver adds the last
guard: with no fresh DriveCommand for ``safety.reaction_timeout_s`` it writes zero itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from navd.config import NavdConfig
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
from navd.lifecycle.module import Module, ModuleContext

__all__ = ["GateSettings", "SafetyGate", "SpeedLimiter"]


@dataclass(frozen=True, slots=True)
class GateSettings:
    """The robot's speed limits, which every command is clamped to.

    Attributes:
        max_forward_mps, max_reverse_mps: [m/s] top speeds forward and backward (>= 0).
        max_yaw_rate_radps: [rad/s] top yaw rate either way.
    """

    max_forward_mps: float
    max_reverse_mps: float
    max_yaw_rate_radps: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> GateSettings:
        """The limits the robot section describes."""
        robot = config.robot
        return cls(
            robot.max_linear_speed_mps, robot.max_reverse_speed_mps, robot.max_angular_speed_radps
        )


class SpeedLimiter(Protocol):
    """Something the gate asks about every command (the collision guard)."""

    def limit(self, linear_mps: float, angular_radps: float) -> tuple[float, float, str]:
        """The command, possibly reduced, and why ("" when untouched)."""


class SafetyGate(Module):
    """Turns requested VelocityCommands into DriveCommands, or zero while unsafe."""

    def __init__(self, limiters: Sequence[SpeedLimiter] = ()) -> None:
        super().__init__("safety")
        self._reasons: dict[str, str] = {}
        self._limiters = tuple(limiters)

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(GateSettings)
        ctx.subscribe(VelocityCommand, self._on_velocity)
        ctx.subscribe(DeviceStale, self._on_stale)
        ctx.subscribe(DeviceLost, self._on_lost)
        ctx.subscribe(DeviceResumed, self._on_back)
        ctx.subscribe(DeviceConnected, self._on_back)
        ctx.subscribe(SafeStop, self._on_safe_stop)
        ctx.subscribe(SafeStopCleared, self._on_cleared)

    def settings_in_use(self) -> tuple[object, ...]:
        return (self.settings.value,)

    @property
    def reasons(self) -> tuple[str, ...]:
        """Why the robot is held still, in the order the reasons arose."""
        return tuple(self._reasons.values())

    def _on_velocity(self, cmd: VelocityCommand) -> None:
        if self._reasons:
            self._drive(0.0, 0.0, "; ".join(self._reasons.values()))
            return
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
        self._drive(linear, angular, "; ".join(reasons))

    def _on_stale(self, msg: DeviceStale) -> None:
        if msg.kind is DeviceKind.LIDAR:
            self._hold(
                f"lidar:{msg.device_id}", f"lidar {msg.device_id!r} silent {msg.silent_s:.2f} s"
            )

    def _on_lost(self, msg: DeviceLost) -> None:
        if msg.kind is DeviceKind.LIDAR:
            self._hold(f"lidar:{msg.device_id}", f"lidar {msg.device_id!r} lost: {msg.reason}")

    def _on_back(self, msg: DeviceResumed | DeviceConnected) -> None:
        if msg.kind is DeviceKind.LIDAR:
            self._release(f"lidar:{msg.device_id}")

    def _on_safe_stop(self, msg: SafeStop) -> None:
        self._hold(msg.key, msg.reason)

    def _on_cleared(self, msg: SafeStopCleared) -> None:
        self._release(msg.key)

    def _hold(self, key: str, text: str) -> None:
        fresh = key not in self._reasons
        self._reasons[key] = text
        if fresh:
            self.ctx.log.warning("safety_hold", reason=text)
            self._drive(0.0, 0.0, text)
            self._publish_state()

    def _release(self, key: str) -> None:
        if self._reasons.pop(key, None) is not None:
            self.ctx.log.info("safety_release", reason=key, remaining=self.reasons)
            self._publish_state()

    def _drive(self, linear: float, angular: float, reason: str) -> None:
        now = self.ctx.clock.now()
        self.ctx.publish(
            DriveCommand(
                stamp=now, received=now, linear_mps=linear, angular_radps=angular, reason=reason
            )
        )

    def _publish_state(self) -> None:
        now = self.ctx.clock.now()
        self.ctx.publish(SafetyState(stamp=now, received=now, reasons=self.reasons))
