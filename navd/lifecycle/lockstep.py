"""Simulated time driven by a simulator, in lockstep (ROS's ``use_sim_time`` with a clock topic).

With ``lifecycle.clock = "simulated"`` the daemon's clock stands still until a clock client
(a simulator) moves it. Each step the simulator names the lines it has sent each device; the
daemon lets any start-up work still running beside the loop finish (the first step may wait
for kernels to compile), waits until it has read the named lines, handles them in device
order (see ``LineCounts``), lets the work they started finish, then moves time to the requested
instant one timer deadline at a time, letting every timer's work (and every worker job it
starts) finish before the next deadline, and answers with the lines it has written each
device (the chassis's wheel commands), so the simulator can read exactly those.
Worker jobs thus take no simulated time (on simulated time the pool runs them on the loop,
in start order): the run is what an infinitely fast computer would do, the same for the same
inputs whatever the machine's load, and as fast as this one allows.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from dataclasses import dataclass

from navd.lifecycle.clock import SimClock
from navd.lifecycle.errors import LifecycleError
from navd.lifecycle.line_counts import LineCounts
from navd.lifecycle.workers import WorkerPool

__all__ = ["Lockstep", "StepReport"]

SETTLE_YIELDS = 20  # loop turns per settle: a message cascade through a few tasks fits


@dataclass(frozen=True, slots=True)
class StepReport:
    """The outcome of one step.

    Attributes:
        time_s: [s] the daemon's time now.
        missing: lines named by the simulator that had not come when the wait timed out
            (empty normally; non-empty means the step went ahead without them).
        sent: lines written to each device so far (cumulative).
    """

    time_s: float
    missing: dict[str, int]
    sent: dict[str, int]


class Lockstep:
    """Moves a SimClock for a simulator. One step at a time; event loop only.

    Args:
        clock: the daemon's simulated clock.
        workers: the pool whose jobs must finish before time moves on.
        line_counts: the drivers' line counters.
    """

    def __init__(self, clock: SimClock, workers: WorkerPool, line_counts: LineCounts) -> None:
        self.clock = clock
        self.workers = workers
        self.line_counts = line_counts
        self._lock = asyncio.Lock()

    async def step_to(
        self, time_s: float, expected: Mapping[str, int], timeout_s: float
    ) -> StepReport:
        """Take in the ``expected`` lines, then move time to ``time_s`` [s].

        Args:
            time_s: [s] where the clock goes; not before its current time.
            expected: per device id, the cumulative lines the simulator has sent it.
            timeout_s: [s] of real time to wait for those lines before going ahead.

        Raises:
            LifecycleError: ``time_s`` is before the current time.
        """
        async with self._lock:
            if time_s < self.clock.now():
                raise LifecycleError(
                    f"simulated time cannot go backwards (from {self.clock.now()} s to {time_s} s)"
                )
            # Work begun beside the loop (kernels compiling at start-up) finishes first, so
            # no job of this step compiles on the loop; only the first step waits here.
            await self.workers.wait_idle()
            missing = await self.line_counts.wait_received(expected, timeout_s)
            self.line_counts.release()
            await self.settle()
            await self.clock.run_to(time_s, settle=self.settle)
            await self.settle()
            return StepReport(self.clock.now(), missing, dict(self.line_counts.sent))

    async def settle(self) -> None:
        """Let the loop run until no task has more to do at this instant and no worker job
        is running or waiting."""
        while True:
            for _ in range(SETTLE_YIELDS):
                await asyncio.sleep(0)
            if not self.workers.busy():
                return
            await self.workers.wait_idle()
