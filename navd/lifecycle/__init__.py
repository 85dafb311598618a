"""The event loop: typed messages, dispatch, workers, module lifecycle, clock, supervision."""

from navd.lifecycle.battery_watch import BatteryWatch
from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import Clock, MonotonicClock, SimClock, ticks
from navd.lifecycle.daemon import Daemon
from navd.lifecycle.errors import (
    DispatchError,
    LifecycleError,
    MessageError,
    ModuleStateError,
    ModuleTimeoutError,
)
from navd.lifecycle.lockstep import Lockstep
from navd.lifecycle.memory_release import release_compiler_code, release_freed_memory
from navd.lifecycle.module import Module, ModuleContext, ModuleManager, ModuleState
from navd.lifecycle.requests import control_message
from navd.lifecycle.safety import ESTOP_REASON, SafetyGate
from navd.lifecycle.settings import Live, parts_of
from navd.lifecycle.state_view import StateView
from navd.lifecycle.stats import percentile
from navd.lifecycle.supervision import Supervisor
from navd.lifecycle.work_script import WorkScript
from navd.lifecycle.workers import WorkerPool

__all__ = [
    "ESTOP_REASON",
    "BatteryWatch",
    "Bus",
    "Clock",
    "Daemon",
    "DispatchError",
    "LifecycleError",
    "Live",
    "Lockstep",
    "MessageError",
    "Module",
    "ModuleContext",
    "ModuleManager",
    "ModuleState",
    "ModuleStateError",
    "ModuleTimeoutError",
    "MonotonicClock",
    "SafetyGate",
    "SimClock",
    "StateView",
    "Supervisor",
    "WorkScript",
    "WorkerPool",
    "control_message",
    "parts_of",
    "percentile",
    "release_compiler_code",
    "release_freed_memory",
    "ticks",
]
