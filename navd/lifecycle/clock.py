"""One injectable clock for the whole daemon.

``MonotonicClock`` is real time. ``SimClock`` is simulated time that only moves when someone
calls ``advance`` (a test, a log replay, a simulator in lockstep); sleepers wake in deadline
order as it passes their deadline, so a run on simulated time is deterministic.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Protocol

from navd.lifecycle.errors import LifecycleError

__all__ = ["Clock", "MonotonicClock", "SimClock", "Tick", "ticks"]


class Clock(Protocol):
    """Where the daemon gets the time and waits for it."""

    def now(self) -> float:
        """[s] current time; only differences are meaningful."""
        ...

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` [s] of this clock's time."""
        ...


class MonotonicClock:
    """Real time from ``time.monotonic``."""

    def now(self) -> float:
        return time.monotonic()

    async def sleep(self, seconds: float) -> None:
        await asyncio.sleep(max(0.0, seconds))


class SimClock:
    """Simulated time that moves only when ``advance`` or ``advance_to`` is called.

    Args:
        start_s: [s] the time ``now`` returns before the first advance.
    """

    def __init__(self, start_s: float = 0.0) -> None:
        self._now = start_s
        self._sleepers: list[tuple[float, int, asyncio.Future[None]]] = []
        self._order = itertools.count()

    def now(self) -> float:
        return self._now

    async def sleep(self, seconds: float) -> None:
        if seconds <= 0.0:
            await asyncio.sleep(0)
            return
        future: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        heapq.heappush(self._sleepers, (self._now + seconds, next(self._order), future))
        await future

    @property
    def pending_sleepers(self) -> int:
        """How many sleeps are waiting for time to pass."""
        return sum(1 for _, _, future in self._sleepers if not future.done())

    def advance(self, seconds: float) -> None:
        """Jump time forward by ``seconds`` [s]; every sleeper whose deadline passed wakes.

        The woken tasks run after the jump, so they see the new time. Use ``run_to`` when each
        sleeper must run at its own deadline (a simulation in lockstep).
        """
        if seconds < 0.0:
            raise LifecycleError(f"simulated time cannot go backwards (advance by {seconds} s)")
        self.advance_to(self._now + seconds)

    def advance_to(self, time_s: float) -> None:
        """Jump time forward to ``time_s`` [s]; wakes sleepers in deadline order."""
        if time_s < self._now:
            raise LifecycleError(
                f"simulated time cannot go backwards (from {self._now} s to {time_s} s)"
            )
        while self._sleepers and self._sleepers[0][0] <= time_s:
            deadline, _, future = heapq.heappop(self._sleepers)
            self._now = deadline
            if not future.done():
                future.set_result(None)
        self._now = time_s

    async def run_to(
        self,
        time_s: float,
        settle_steps: int = 10,
        settle: Callable[[], Awaitable[None]] | None = None,
    ) -> None:
        """Step time forward to ``time_s`` [s], one deadline at a time.

        At each deadline the sleepers due are woken and the loop is let run (``settle_steps``
        yields, or ``settle()`` when given) before time moves on, so each task sees its own
        deadline and a periodic task fires once per period, in order, deterministically.
        """
        if time_s < self._now:
            raise LifecycleError(
                f"simulated time cannot go backwards (from {self._now} s to {time_s} s)"
            )
        while self._sleepers and self._sleepers[0][0] <= time_s:
            deadline = self._sleepers[0][0]
            self._now = max(self._now, deadline)
            while self._sleepers and self._sleepers[0][0] <= deadline:
                _, _, future = heapq.heappop(self._sleepers)
                if not future.done():
                    future.set_result(None)
            if settle is not None:
                await settle()
            else:
                for _ in range(settle_steps):
                    await asyncio.sleep(0)
        self._now = time_s


class Tick:
    """One tick of a fixed-rate loop.

    Attributes:
        index: 0 for the first tick; skipped ticks are not numbered.
        scheduled_s: [s] when the tick was due.
        late_s: [s] how late it started (the loop's jitter).
        skipped: ticks missed since the previous one because the loop fell behind.
    """

    __slots__ = ("index", "late_s", "scheduled_s", "skipped")

    def __init__(self, index: int, scheduled_s: float, late_s: float, skipped: int) -> None:
        self.index = index
        self.scheduled_s = scheduled_s
        self.late_s = late_s
        self.skipped = skipped


async def ticks(
    clock: Clock, period_s: float | Callable[[], float], limit: int | None = None
) -> AsyncIterator[Tick]:
    """Yield ticks every ``period_s`` [s] without drift.

    Deadlines are ``start + k * period``; when the consumer falls more than a period behind,
    the missed deadlines are skipped (and counted) rather than fired in a burst. A callable
    period is read after every tick: a new value takes effect from the next deadline, which
    becomes the start of the new grid.

    Args:
        clock: the time source.
        period_s: [s] tick period, > 0, or a function returning the period in force.
        limit: stop after this many ticks (for tests); None runs forever.

    Raises:
        LifecycleError: a period that is not > 0.
    """
    period = period_s if callable(period_s) else (lambda: period_s)
    step = _positive(period())
    start = clock.now()
    k = 0
    index = 0
    while limit is None or index < limit:
        deadline = start + k * step
        await clock.sleep(deadline - clock.now())
        now = clock.now()
        late = now - deadline
        skipped = int(late // step) if late >= step else 0
        yield Tick(index, deadline, late, skipped)
        index += 1
        k += 1 + skipped
        new_step = _positive(period())
        if new_step != step:
            start, k, step = start + k * step - step + new_step, 0, new_step


def _positive(period_s: float) -> float:
    if not period_s > 0.0:
        raise LifecycleError(f"tick period must be > 0 s, got {period_s}")
    return period_s
