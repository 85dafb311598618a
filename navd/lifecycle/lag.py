"""Event-loop lag: how long a new event waits before the loop handles it, measured continuously.

Every ``period_s`` a small thread hands the loop a callback stamped with the moment it did, as
a socket or a worker result would arrive, and the loop records how long the callback waited
to run. High lag means something blocked the loop: a handler doing heavy work. (A probe that
sleeps on the loop and records how late it woke would measure the loop's timer granularity as
well: uvloop rounds timers to whole milliseconds, so it reads up to 1 ms on an idle loop.)
"""

from __future__ import annotations

import asyncio
import threading
import time

from navd.lifecycle.stats import RollingWindow

__all__ = ["LoopLagMonitor"]


class LoopLagMonitor:
    """Samples event-loop lag into a rolling window.

    Args:
        period_s: [s] time between probes.
        window: how many recent samples the percentiles cover.
    """

    def __init__(self, period_s: float, window: int) -> None:
        self.period_s = period_s
        self.samples = RollingWindow(window)

    async def run(self) -> None:
        """Probe until cancelled."""
        loop = asyncio.get_running_loop()
        stop = threading.Event()
        thread = threading.Thread(
            target=self._probe, args=(loop, stop), name="navd-lag-probe", daemon=True
        )
        thread.start()
        try:
            await loop.create_future()  # never done: runs until cancelled
        finally:
            stop.set()

    def _probe(self, loop: asyncio.AbstractEventLoop, stop: threading.Event) -> None:
        while not stop.wait(self.period_s):
            try:
                loop.call_soon_threadsafe(self._record, time.perf_counter())
            except RuntimeError:  # the loop has closed
                return

    def _record(self, handed_s: float) -> None:
        self.samples.add(time.perf_counter() - handed_s)

    def snapshot_ms(self) -> tuple[float, float, float]:
        """[ms] (p50, p99, max) of the recent lag samples."""
        p50, p99, worst = self.samples.percentiles((50.0, 99.0, 100.0))
        return p50 * 1e3, p99 * 1e3, worst * 1e3
