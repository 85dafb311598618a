"""Asking the kernel to run the event-loop thread soon after it wakes.

Under the nominal load the event loop's worst waits (3-4 ms, its lag p99 over the 2 ms
target in some runs) were its thread waiting runnable on the run queue, with no Python
running anywhere in the daemon: another task was using up its time slice
(``/proc/self/task/TID/schedstat`` counted the wait as run-queue delay). Linux's EEVDF
scheduler lets a task ask for a shorter slice (``sched_attr.sched_runtime`` of a SCHED_OTHER
task, honoured from Linux 6.12): its virtual deadlines come sooner, so when it wakes it
preempts a task that runs with the default slice instead of waiting for that slice to end.
No privilege is needed. A kernel before 6.12 has no slice of its own per task: there the
request changes nothing (or is refused, and the daemon runs on as before).
"""

from __future__ import annotations

import ctypes
import functools
import os
import platform
import sys
from collections.abc import Callable

__all__ = ["request_slice", "thread_slice_s"]

# sched_setattr and sched_getattr by machine (Linux's syscall tables).
_SYSCALLS = {"x86_64": (314, 315), "aarch64": (274, 275)}
_SCHED_OTHER = 0


class _SchedAttr(ctypes.Structure):
    """Linux's ``struct sched_attr``, its first version (48 bytes)."""

    _fields_ = [
        ("size", ctypes.c_uint32),
        ("sched_policy", ctypes.c_uint32),
        ("sched_flags", ctypes.c_uint64),
        ("sched_nice", ctypes.c_int32),
        ("sched_priority", ctypes.c_uint32),
        ("sched_runtime", ctypes.c_uint64),
        ("sched_deadline", ctypes.c_uint64),
        ("sched_period", ctypes.c_uint64),
    ]


def request_slice(slice_s: float) -> bool:
    """Ask the kernel for a ``slice_s`` [s] time slice for the calling thread, keeping its
    nice value; False where there is no such call (another system or machine), where the
    thread runs under another policy than the normal one (a real-time or batch policy the
    service was given is left as it is), or where the kernel refused it."""
    calls = _calls()
    current = _attributes()
    if calls is None or current is None or current.sched_policy != _SCHED_OTHER:
        return False
    syscall, (set_attr, _) = calls
    attr = _SchedAttr(
        size=ctypes.sizeof(_SchedAttr),
        sched_policy=_SCHED_OTHER,
        sched_nice=os.getpriority(os.PRIO_PROCESS, 0),
        sched_runtime=round(slice_s * 1e9),
    )
    return bool(syscall(set_attr, 0, ctypes.byref(attr), 0) == 0)


def thread_slice_s() -> float | None:
    """[s] the time slice the calling thread runs with, or None where the kernel does not say
    (another system, or a kernel whose scheduler has no slice of its own per task)."""
    attr = _attributes()
    return attr.sched_runtime / 1e9 if attr is not None and attr.sched_runtime else None


def _attributes() -> _SchedAttr | None:
    """The calling thread's scheduling attributes, or None where they cannot be read."""
    calls = _calls()
    if calls is None:
        return None
    syscall, (_, get_attr) = calls
    attr = _SchedAttr()
    if syscall(get_attr, 0, ctypes.byref(attr), ctypes.sizeof(_SchedAttr), 0) != 0:
        return None
    return attr


def _calls() -> tuple[Callable[..., int], tuple[int, int]] | None:
    """libc's ``syscall`` and this machine's (sched_setattr, sched_getattr) numbers; None
    where either is missing."""
    syscall = _syscall()
    numbers = _SYSCALLS.get(platform.machine())
    return None if syscall is None or numbers is None else (syscall, numbers)


@functools.cache
def _syscall() -> Callable[..., int] | None:
    """libc's ``syscall``, looked up once; None off Linux."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        call: Callable[..., int] = ctypes.CDLL(None, use_errno=True).syscall
    except (OSError, AttributeError):
        return None
    return call
