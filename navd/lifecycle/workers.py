"""A worker pool for heavy jobs, with one "latest wins" slot per kind of job.

Each slot runs at most one job at a time and holds at most one waiting job: a newer job of the
same kind replaces the waiting one, and the replaced job is counted as dropped, so no queue
grows without bound and the worker always works on the freshest input. A job returns a
Message (published on the bus when it completes, on the event loop) or None. A job that
raises is reported to the bus's supervision as a failure of its module.

Jobs run in threads: their heavy parts should be numba kernels compiled with ``nogil=True``
or library calls that release the GIL, so the event loop keeps running. Each job's timing
(submitted, begun, published, or dropped) goes on the bus as a ``WorkerJob``, which a
recording keeps. On simulated time (``inline``) jobs run on the event loop instead, one after
another in the order they were started, so a simulation never depends on how threads happen
to be scheduled; a replay that ``follow``s a recorded run's jobs runs each as its recorded
counterpart did (``work_script``).
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import math
import threading
import time
from collections.abc import Callable, Coroutine
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

from navd.lifecycle.bus import Bus
from navd.lifecycle.errors import LifecycleError
from navd.lifecycle.memory_release import release_compiler_code, release_freed_memory
from navd.lifecycle.messages import Message, SetUpDone, WorkerJob, WorkerStats
from navd.lifecycle.work_script import RecordedJob, WorkScript
from navd.logs import get_logger

__all__ = ["Job", "WorkerPool"]

_log = get_logger("lifecycle.workers")

Job = Callable[[], Message | tuple[Message, ...] | None]
_Result = Future[Message | tuple[Message, ...] | None]


@dataclass
class _Slot:
    module: str
    running: bool = False
    waiting: Job | None = None
    waiting_since: float = 0.0  # [s] when the waiting job was submitted
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
        self._script: WorkScript | None = None
        self._following: set[asyncio.Task[None]] = set()

    def follow(self, script: WorkScript) -> None:
        """Run each job (``inline`` only) as its counterpart in a recorded run did: dropped,
        or begun and published after the recorded delays (``work_script``)."""
        if not self.inline:
            raise LifecycleError("only a pool on simulated time can follow a recorded run")
        self._script = script

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
        now = self._bus.clock.now()
        if self._script is not None:
            recorded = self._script.take(slot, now)
            if recorded is not None:
                self._as_recorded(slot, state, job, recorded)
                return
        if state.running:
            if state.waiting is not None:
                state.dropped += 1
                self._timing(slot, state.waiting_since, math.nan, "dropped")
            state.waiting, state.waiting_since = job, now
            return
        self._start(slot, state, job, now)

    def stats(self) -> tuple[WorkerStats, ...]:
        """Counters of every slot, by first use."""
        return tuple(
            WorkerStats(name, s.submitted, s.completed, s.dropped, s.failed)
            for name, s in self._slots.items()
        )

    def run_detached(
        self,
        job: Callable[[], None],
        *,
        name: str,
        module: str,
        then: Callable[[], None] | None = None,
    ) -> None:
        """Run ``job`` once in its own daemon thread (a slow set-up that must never hold up
        the process's exit); it counts as work in progress for ``busy`` and ``wait_idle``.
        An exception is reported to supervision as a failure of ``module``. Once it is done,
        ``then()`` runs on the event loop, and a ``SetUpDone`` says when; a replay following
        a recorded run calls ``then()`` when the recorded one took effect."""
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
                done = functools.partial(self._detached_done, name, module, error, then=then)
                loop.call_soon_threadsafe(done, seconds, released)

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
        for task in self._following:
            task.cancel()
        self._executor.shutdown(wait=False, cancel_futures=True)

    def _start(self, slot: str, state: _Slot, job: Job, submitted_s: float) -> None:
        loop = asyncio.get_running_loop()
        state.running = True
        if self.inline:
            loop.call_soon(self._run_inline, slot, state, job)
            return
        clock = self._bus.clock
        began = [math.nan]

        def run() -> Message | tuple[Message, ...] | None:
            began[0] = clock.now()
            return job()

        future = self._executor.submit(run)

        def finished(done: _Result) -> None:
            # A job may outlive the loop (the daemon failed to start, or is stopping).
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(self._finished, slot, state, done, submitted_s, began)

        future.add_done_callback(finished)

    def _run_inline(self, slot: str, state: _Slot, job: Job) -> None:
        self._finished(slot, state, self._run_now(job), math.nan, [math.nan])

    def _run_now(self, job: Job) -> _Result:
        done: _Result = Future()
        if not self._closed:
            try:
                done.set_result(job())
            except Exception as err:
                done.set_exception(err)
        else:
            done.set_result(None)
        return done

    def _as_recorded(self, slot: str, state: _Slot, job: Job, recorded: RecordedJob) -> None:
        """Run ``job`` as ``recorded`` went: not at all, or begun and published after its
        delays on the (simulated) clock. It is not work in progress for ``busy``: the clock
        must move for it to run."""
        if recorded.dropped:
            state.dropped += 1
            return
        clock = self._bus.clock

        async def run() -> None:
            await clock.sleep(recorded.start_after_s)
            done = self._run_now(job)
            await clock.sleep(recorded.finish_after_s - recorded.start_after_s)
            if not self._closed:
                self._outcome(slot, state, done)

        self._follow(run(), f"replayed-{slot}")

    def _finished(
        self, slot: str, state: _Slot, future: _Result, submitted_s: float, began: list[float]
    ) -> None:
        state.running = False
        if self._closed:
            self._wake_idle_waiters()
            return
        outcome = self._outcome(slot, state, future)
        if not self.inline:
            self._timing(slot, submitted_s, began[0], outcome)
        if state.waiting is not None:
            job, state.waiting = state.waiting, None
            self._start(slot, state, job, state.waiting_since)
        self._wake_idle_waiters()

    def _outcome(self, slot: str, state: _Slot, future: _Result) -> str:
        """Publish the job's result, or report its failure; "done" or "failed"."""
        error = future.exception()
        if error is not None:
            state.failed += 1
            self._bus.report_failure(state.module, {"worker_slot": slot}, error)
            return "failed"
        state.completed += 1
        result = future.result()
        for message in result if isinstance(result, tuple) else (result,):
            if message is not None:
                self._bus.publish(message)
        return "done"

    def _timing(self, slot: str, submitted_s: float, began_s: float, outcome: str) -> None:
        """The job's timing on the bus (real time only: a recording keeps it)."""
        if self.inline:
            return
        now = self._bus.clock.now()
        finished = math.nan if outcome == "dropped" else now
        self._bus.publish(
            WorkerJob(
                stamp=now,
                received=now,
                slot=slot,
                submitted_s=submitted_s,
                started_s=began_s,
                finished_s=finished,
                outcome=outcome,
            )
        )

    def _detached_done(
        self,
        name: str,
        module: str,
        error: Exception | None,
        seconds: float,
        released: int,
        *,
        then: Callable[[], None] | None,
    ) -> None:
        self._detached -= 1
        if error is not None:
            self._bus.report_failure(module, {"thread": name}, error)
        else:
            # Set-ups are kernels compiling or loading: a cold cache shows here in seconds.
            extra = {"compiler_code_released_mb": round(released / 2**20, 1)} if released else {}
            _log.info("set_up_done", thread=name, seconds=round(seconds, 3), **extra)
            due = None if self._script is None else self._script.set_up_at(name)
            if due is not None and then is not None:
                self._follow(self._then_when_recorded(due, then), f"replayed-{name}")
            else:
                self._effect(name, then)
        self._wake_idle_waiters()

    def _effect(self, name: str, then: Callable[[], None] | None) -> None:
        """A set-up takes effect now (said on the bus on a real run)."""
        if then is not None:
            then()
        if not self.inline:
            now = self._bus.clock.now()
            self._bus.publish(SetUpDone(stamp=now, received=now, name=name))

    async def _then_when_recorded(self, due: float, then: Callable[[], None]) -> None:
        """``then()`` at ``due`` [s] on the recorded run's clock, once the replay knows its
        own (a set-up recorded as done before the first input takes effect at once)."""
        assert self._script is not None
        await self._script.known.wait()
        clock = self._bus.clock
        await clock.sleep(due + self._script.shift_s - clock.now())
        then()

    def _follow(self, coro: Coroutine[Any, Any, None], name: str) -> None:
        task = asyncio.get_running_loop().create_task(coro, name=name)
        self._following.add(task)
        task.add_done_callback(self._following.discard)

    def _wake_idle_waiters(self) -> None:
        if self._idle_waiters and not self.busy():
            waiters, self._idle_waiters = self._idle_waiters, []
            for waiter in waiters:
                if not waiter.done():
                    waiter.set_result(None)
