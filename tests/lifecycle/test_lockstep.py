from __future__ import annotations

import asyncio
import functools
import time

import pytest

from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import SimClock, ticks
from navd.lifecycle.errors import LifecycleError
from navd.lifecycle.line_counts import LineCounts
from navd.lifecycle.lockstep import Lockstep
from navd.lifecycle.messages import VelocityCommand
from navd.lifecycle.workers import WorkerPool
from tests.conftest import velocity


def _slow_job(value: float) -> VelocityCommand:
    time.sleep(0.02)  # real time a worker spends; simulated time must not pass meanwhile
    return velocity(value)


async def test_timers_fire_at_each_deadline_and_their_worker_jobs_finish_before_time_moves(
    clock: SimClock, bus: Bus
) -> None:
    pool = WorkerPool(bus, threads=2)
    lockstep = Lockstep(clock, pool, LineCounts())
    ticked: list[float] = []
    results: list[tuple[float, float]] = []  # (job value, simulated time of its result)
    bus.subscribe(
        VelocityCommand, lambda m: results.append((m.linear_mps, clock.now())), module="rec"
    )

    async def timer() -> None:
        async for tick in ticks(clock, 0.1):
            ticked.append(clock.now())
            pool.submit("plan", functools.partial(_slow_job, float(tick.index)), module="planner")

    task = asyncio.create_task(timer())
    t0 = clock.now()
    report = await lockstep.step_to(t0 + 0.35, {}, timeout_s=1.0)
    assert report.time_s == clock.now() == t0 + 0.35
    assert ticked == pytest.approx([t0, t0 + 0.1, t0 + 0.2, t0 + 0.3])
    # every result came at the deadline its job was started at: none dropped, none late
    assert [v for v, _ in results] == [0.0, 1.0, 2.0, 3.0]
    assert [t for _, t in results] == pytest.approx(ticked)
    task.cancel()
    pool.close()


async def test_a_step_takes_in_the_named_lines_before_time_moves(clock: SimClock, bus: Bus) -> None:
    counts = LineCounts()
    lockstep = Lockstep(clock, WorkerPool(bus, threads=1), counts)
    arrived_at: list[float] = []

    async def lidar() -> None:
        for _ in range(3):
            await asyncio.sleep(0.01)  # the lines are slow to come, in real time
            counts.add_received("lidar0")
            arrived_at.append(clock.now())

    t0 = clock.now()
    feeder = asyncio.create_task(lidar())
    counts.add_sent("chassis", 7)
    report = await lockstep.step_to(t0 + 1.0, {"lidar0": 3}, timeout_s=5.0)
    await feeder
    assert arrived_at == [t0, t0, t0]
    assert report.missing == {}
    assert report.sent == {"chassis": 7}
    assert clock.now() == t0 + 1.0


async def test_lines_that_never_come_are_reported_and_time_moves_on(
    clock: SimClock, bus: Bus
) -> None:
    lockstep = Lockstep(clock, WorkerPool(bus, threads=1), LineCounts())
    report = await lockstep.step_to(clock.now() + 0.5, {"imu0": 2}, timeout_s=0.05)
    assert report.missing == {"imu0": 2}
    assert report.time_s == clock.now()


async def test_time_never_goes_backwards(clock: SimClock, bus: Bus) -> None:
    lockstep = Lockstep(clock, WorkerPool(bus, threads=1), LineCounts())
    later = clock.now() + 2.0
    await lockstep.step_to(later, {}, timeout_s=1.0)
    with pytest.raises(LifecycleError, match="cannot go backwards"):
        await lockstep.step_to(later - 1.0, {}, timeout_s=1.0)
    assert clock.now() == later
