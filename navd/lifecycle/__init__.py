"""The event loop: typed messages, dispatch, workers, module lifecycle, clock, supervision."""

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
from navd.lifecycle.module import Module, ModuleContext, ModuleManager, ModuleState
from navd.lifecycle.supervision import Supervisor
from navd.lifecycle.workers import WorkerPool

__all__ = [
    "Bus",
    "Clock",
    "Daemon",
    "DispatchError",
    "LifecycleError",
    "MessageError",
    "Module",
    "ModuleContext",
    "ModuleManager",
    "ModuleState",
    "ModuleStateError",
    "ModuleTimeoutError",
    "MonotonicClock",
    "SimClock",
    "Supervisor",
    "WorkerPool",
    "ticks",
]
