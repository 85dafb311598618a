"""Event-loop lag: how late a timer fires, measured continuously.

The probe sleeps ``period_s`` on the loop's own (real) clock and records how much later than
asked it woke. High lag means something blocked the loop: a handler doing heavy work.
"""

from __future__ import annotations

import asyncio

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
        loop = asyncio.get_running_loop()
        while True:
            asked = loop.time() + self.period_s
            await asyncio.sleep(self.period_s)
            self.samples.add(max(0.0, loop.time() - asked))

    def snapshot_ms(self) -> tuple[float, float, float]:
        """[ms] (p50, p99, max) of the recent lag samples."""
        s = self.samples
        return s.percentile(50) * 1e3, s.percentile(99) * 1e3, s.max() * 1e3
