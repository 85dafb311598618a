"""A worker pool for heavy jobs, with one "latest wins" slot per kind of job.

Each slot runs at most one job at a time and holds at most one waiting job: a newer job of the
same kind replaces the waiting one, and the replaced job is counted as dropped, so no queue
grows without bound and the worker always works on the freshest input. A job returns a
Message (published on the bus when it completes, on the event loop) or None. A job that
raises is reported to the bus's supervision as a failure of its module.

Jobs run in threads: their heavy parts should be numba kernels compiled with ``nogil=True``
or library calls that release the GIL, so the event loop keeps running. On simulated time
(``inline``) they run on the event loop instead, one after another in the order they were
started, so a simulation never depends on how threads happen to be scheduled.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

from navd.lifecycle.bus import Bus
from navd.lifecycle.errors import LifecycleError
from navd.lifecycle.memory_release import release_compiler_code, release_freed_memory
from navd.lifecycle.messages import Message, WorkerStats
from navd.logs import get_logger

__all__ = ["Job", "WorkerPool"]

_log = get_logger("lifecycle.workers")

Job = Callable[[], Message | tuple[Message, ...] | None]


@dataclass
class _Slot:
    module: str
    running: bool = False
    waiting: Job | None = None
    submitted: int = 0
    completed: int = 0
    dropped: int = 0
    failed: int = 0


class WorkerPool:
    """Threads for heavy jobs, fed through latest-wins slots. Use from the event loop only.

    Args:
        bus: where results are published and failures reported.
        threads: number of worker threads.
        inline: run each job on the event loop, in start order (for simulated time).
    """

    def __init__(self, bus: Bus, threads: int, *, inline: bool = False) -> None:
        self._bus = bus
        self.inline = inline
        self._executor = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="navd-worker")
        self._slots: dict[str, _Slot] = {}
        self._detached = 0
        self._threads: list[threading.Thread] = []
        self._idle_waiters: list[asyncio.Future[None]] = []
        self._closed = False

    def submit(self, slot: str, job: Job, *, module: str) -> None:
        """Run ``job`` in a worker; if the slot is busy, it waits, replacing any waiting job.

        Args:
            slot: the kind of job ("scan_match", "global_plan"...); one runs at a time.
            job: a function of no arguments returning a Message, a tuple of them, or None.
            module: the module that owns the slot (failures count against it).

        Raises:
            LifecycleError: the pool is closed, or the slot belongs to another module.
        """
        if self._closed:
            raise LifecycleError(f"worker pool is closed; cannot run a {slot!r} job")
        state = self._slots.setdefault(slot, _Slot(module))
        if state.module != module:
            raise LifecycleError(
                f"worker slot {slot!r} belongs to module {state.module!r}, not {module!r}"
            )
        state.submitted += 1
        if state.running:
            if state.waiting is not None:
                state.dropped += 1
            state.waiting = job
            return
        self._start(slot, state, job)

    def stats(self) -> tuple[WorkerStats, ...]:
        """Counters of every slot, by first use."""
        return tuple(
            WorkerStats(name, s.submitted, s.completed, s.dropped, s.failed)
            for name, s in self._slots.items()
        )

    def run_detached(self, job: Callable[[], None], *, name: str, module: str) -> None:
        """Run ``job`` once in its own daemon thread (a slow set-up that must never hold up
        the process's exit); it counts as work in progress for ``busy`` and ``wait_idle``.
        An exception is reported to supervision as a failure of ``module``."""
        loop = asyncio.get_running_loop()
        self._detached += 1
        started = time.perf_counter()

        def run() -> None:
            error: Exception | None = None
            try:
                job()
            except Exception as err:
                error = err
            seconds = time.perf_counter() - started
            # What compiling and loading freed, back to the system: here, not on the loop
            # (glibc walks its heap; ctypes lets go of the interpreter meanwhile).
            release_freed_memory()
            # LLVM's code pages out of the resident set as each set-up ends, not only after
            # the last: a set-up still loading kernels reads back from the page cache only
            # the pages it runs, which keeps the start-up peak lower (docs/performance.md).
            released = release_compiler_code()
            with contextlib.suppress(RuntimeError):  # the loop may be gone
                loop.call_soon_threadsafe(
                    self._detached_done, name, module, error, seconds, released
                )

        thread = threading.Thread(target=run, name=name, daemon=True)
        self._threads = [t for t in self._threads if t.is_alive()] + [thread]
        thread.start()

    def unfinished_threads(self) -> list[str]:
        """Names of the ``run_detached`` threads still running (for a process about to exit:
        interpreter shutdown under a thread inside a compiler can abort the process)."""
        return [t.name for t in self._threads if t.is_alive()]

    def busy(self) -> bool:
        """True while any job is running or waiting."""
        return self._detached > 0 or any(
            s.running or s.waiting is not None for s in self._slots.values()
        )

    async def wait_idle(self) -> None:
        """Return once no job is running or waiting (at once if none is)."""
        if not self.busy():
            return
        waiter = asyncio.get_running_loop().create_future()
        self._idle_waiters.append(waiter)
        await waiter

    def close(self) -> None:
        """Stop accepting jobs, drop waiting ones and let running ones finish unobserved."""
        self._closed = True
        for state in self._slots.values():
            if state.waiting is not None:
                state.dropped += 1
                state.waiting = None
        self._executor.shutdown(wait=False, cancel_futures=True)

    def _start(self, slot: str, state: _Slot, job: Job) -> None:
        loop = asyncio.get_running_loop()
        state.running = True
        if self.inline:
            loop.call_soon(self._run_inline, slot, state, job)
            return
        future = self._executor.submit(job)

        def finished(done: Future[Message | tuple[Message, ...] | None]) -> None:
            # A job may outlive the loop (the daemon failed to start, or is stopping).
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(self._finished, slot, state, done)

        future.add_done_callback(finished)

    def _run_inline(self, slot: str, state: _Slot, job: Job) -> None:
        done: Future[Message | tuple[Message, ...] | None] = Future()
        if not self._closed:
            try:
                done.set_result(job())
            except Exception as err:
                done.set_exception(err)
        else:
            done.set_result(None)
        self._finished(slot, state, done)

    def _finished(
        self, slot: str, state: _Slot, future: Future[Message | tuple[Message, ...] | None]
    ) -> None:
        state.running = False
        if self._closed:
            self._wake_idle_waiters()
            return
        error = future.exception()
        if error is not None:
            state.failed += 1
            self._bus.report_failure(state.module, {"worker_slot": slot}, error)
        else:
            state.completed += 1
            result = future.result()
            for message in result if isinstance(result, tuple) else (result,):
                if message is not None:
                    self._bus.publish(message)
        if state.waiting is not None:
            job, state.waiting = state.waiting, None
            self._start(slot, state, job)
        self._wake_idle_waiters()

    def _detached_done(
        self, name: str, module: str, error: Exception | None, seconds: float, released: int
    ) -> None:
        self._detached -= 1
        if error is not None:
            self._bus.report_failure(module, {"thread": name}, error)
        else:
            # Set-ups are kernels compiling or loading: a cold cache shows here in seconds.
            extra = {"compiler_code_released_mb": round(released / 2**20, 1)} if released else {}
            _log.info("set_up_done", thread=name, seconds=round(seconds, 3), **extra)
        self._wake_idle_waiters()

    def _wake_idle_waiters(self) -> None:
        if self._idle_waiters and not self.busy():
            waiters, self._idle_waiters = self._idle_waiters, []
            for waiter in waiters:
                if not waiter.done():
                    waiter.set_result(None)
