"""The lifecycle room's settings: dispatch, supervision, probes, logging, and the limits the
safety gate clamps every command to; the only place the room derives values from the config."""

from __future__ import annotations

from dataclasses import dataclass

from navd.config import NavdConfig
from navd.geometry import RobotLimits

__all__ = ["BatteryLevels", "LifecycleSettings", "LoggingSettings", "gate_limits"]


@dataclass(frozen=True, slots=True)
class LifecycleSettings:
    """What the bus, the supervisor, the probes and the module manager run on.

    Attributes:
        handler_budget_s: [s] a handler taking longer is counted as slow.
        max_cascade: [messages] most messages handlers may publish in one dispatch.
        max_failures: [count] failures within ``failure_window_s`` that fault a module.
        failure_window_s: [s] the window failures are counted over.
        lag_period_s: [s] period of the event-loop lag probe.
        transition_timeout_s: [s] longest a module may take to start or stop.
        status_period_s: [s] period of the DaemonStatus message.
    """

    handler_budget_s: float
    max_cascade: int
    max_failures: int
    failure_window_s: float
    lag_period_s: float
    transition_timeout_s: float
    status_period_s: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> LifecycleSettings:
        """The settings the lifecycle section describes."""
        lc = config.lifecycle
        return cls(
            handler_budget_s=lc.handler_budget_ms / 1e3,
            max_cascade=lc.max_dispatch_cascade,
            max_failures=lc.max_handler_failures,
            failure_window_s=lc.failure_window_s,
            lag_period_s=lc.lag_sample_period_s,
            transition_timeout_s=lc.transition_timeout_s,
            status_period_s=1.0 / lc.status_rate_hz,
        )


@dataclass(frozen=True, slots=True)
class LoggingSettings:
    """The lowest level written, and how often the status is logged.

    Attributes:
        level: "debug", "info", "warning" or "error".
        status_log_period_s: [s] period of the status log line; 0 never.
    """

    level: str
    status_log_period_s: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> LoggingSettings:
        """The settings the logging section describes."""
        return cls(config.logging.level, config.logging.status_log_period_s)


def gate_limits(config: NavdConfig) -> RobotLimits:
    """The robot's limits, which the safety gate clamps every command to."""
    return RobotLimits.of(config.robot)


@dataclass(frozen=True, slots=True)
class BatteryLevels:
    """[0, 1] the charges at which the battery is low and critical, and the margin above a
    threshold at which its alarm ends."""

    low: float
    critical: float
    recover: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> BatteryLevels:
        """The levels the battery section describes."""
        b = config.battery
        return cls(b.low_percent / 100.0, b.critical_percent / 100.0, b.recover_percent / 100.0)
