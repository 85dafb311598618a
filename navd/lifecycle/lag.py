"""Event-loop lag: how late a timer fires, measured continuously.

The probe sleeps ``period_s`` on the loop's own (real) clock and records how much later than
asked it woke. High lag means something blocked the loop: a handler doing heavy work.
"""

from __future__ import annotations

import asyncio
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
        """Probe forever (until cancelled)."""
        # perf_counter, not loop.time(): uvloop's loop clock only has millisecond resolution
        while True:
            asked = time.perf_counter() + self.period_s
            await asyncio.sleep(self.period_s)
            self.samples.add(max(0.0, time.perf_counter() - asked))

    def snapshot_ms(self) -> tuple[float, float, float]:
        """[ms] (p50, p99, max) of the recent lag samples."""
        p50, p99, worst = self.samples.percentiles((50.0, 99.0, 100.0))
        return p50 * 1e3, p99 * 1e3, worst * 1e3
