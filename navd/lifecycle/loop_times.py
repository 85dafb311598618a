"""When the modules' periodic loops tick: kept on a real run, followed by a replay.

On real time a loop's tick comes late, or a few are skipped, when the event loop is held up
(a busy machine, kernels loading at start-up); the control loop then plans a step later
and the run goes another way than a replay whose ticks come on time. So a real run's ticks
go on the bus as ``LoopTicks`` (one message a loop per ``BATCH_S``, which a recording keeps),
and a replay that ``follow``s them ticks each loop at the recorded times (shifted to its own
clock), and on its own period before the first and after the last.
"""

from __future__ import annotations

import bisect
from collections.abc import AsyncIterator, Callable, Iterable

from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import ticks
from navd.lifecycle.errors import LifecycleError
from navd.lifecycle.messages import LoopTicks

__all__ = ["BATCH_S", "LoopTimes"]

BATCH_S = 1.0  # [s] a loop's ticks go on the bus together, this often


class LoopTimes:
    """The periodic loops' ticks, told (``record``) or followed (``follow``).

    Args:
        bus: where the ticks go, and whose clock they are on.
        record: tell each tick (a real-time run); else ticks are only kept to.
    """

    def __init__(self, bus: Bus, *, record: bool) -> None:
        self._bus = bus
        self._record = record
        self._heard: dict[str, list[float]] = {}
        self._script: dict[str, list[float]] | None = None
        self._next: dict[str, int] = {}
        self.shift_s: float | None = None  # [s] replay time minus recorded time, once known

    def follow(self, recorded: Iterable[LoopTicks]) -> None:
        """Tick each loop at these recorded times, once ``shift_s`` is set."""
        if self._record:
            raise LifecycleError("a run that records its ticks cannot follow recorded ones")
        script: dict[str, list[float]] = {}
        for batch in recorded:
            script.setdefault(batch.loop, []).extend(batch.times_s)
        for times in script.values():
            times.sort()
        self._script = script
        self._next = dict.fromkeys(script, 0)

    async def ticks(self, loop: str, period_s: float | Callable[[], float]) -> AsyncIterator[float]:
        """[s] the time of each tick of ``loop`` (``"<module>.<name>"``), every ``period_s``
        (or a function giving the period in force), or as recorded when followed."""
        clock = self._bus.clock
        if self._script is None or loop not in self._script:
            async for _ in ticks(clock, period_s):
                now = clock.now()
                if self._record:
                    self._told(loop, now)
                yield now
            return
        period = period_s if callable(period_s) else (lambda: period_s)
        wait = 0.0  # the first tick at once, as on a real run
        while True:
            due = self._due(loop, clock.now())
            await clock.sleep(due - clock.now() if due is not None else wait)
            wait = period()
            yield clock.now()

    def _due(self, loop: str, now: float) -> float | None:
        """The next recorded tick of ``loop`` at or after ``now`` (replay time), or None
        when the shift is not known yet or the recorded ticks are over."""
        if self._script is None or self.shift_s is None:
            return None
        times = self._script[loop]
        i = max(self._next[loop], bisect.bisect_left(times, now - self.shift_s - 1e-9))
        if i >= len(times):
            return None
        self._next[loop] = i + 1
        return times[i] + self.shift_s

    def _told(self, loop: str, now: float) -> None:
        heard = self._heard.setdefault(loop, [])
        heard.append(now)
        if now - heard[0] >= BATCH_S:
            self._bus.publish(LoopTicks(stamp=now, received=now, loop=loop, times_s=tuple(heard)))
            heard.clear()
