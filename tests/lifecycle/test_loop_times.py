"""A periodic loop's ticks: told on the bus about once a second on a real run, and, followed
in a replay, at the recorded times (shifted), on the loop's own period before and after."""

from __future__ import annotations

import asyncio

import pytest

from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import MonotonicClock, SimClock
from navd.lifecycle.errors import LifecycleError
from navd.lifecycle.loop_times import BATCH_S, LoopTimes
from navd.lifecycle.messages import LoopTicks
from navd.lifecycle.supervision import Supervisor


def _bus(clock: SimClock | MonotonicClock) -> Bus:
    supervisor = Supervisor(max_failures=3, window_s=10.0)
    return Bus(clock, supervisor, handler_budget_s=10.0, max_cascade=100)


async def test_a_real_runs_ticks_are_told_in_batches_of_about_a_second() -> None:
    clock = SimClock(50.0)
    bus = _bus(clock)
    told: list[LoopTicks] = []
    bus.subscribe(LoopTicks, told.append, module="rec")
    times = LoopTimes(bus, record=True)
    seen: list[float] = []

    async def loop() -> None:
        async for now in times.ticks("planner.control", 0.25):
            seen.append(now)

    task = asyncio.create_task(loop())
    for _ in range(5):
        await asyncio.sleep(0)  # the loop waits for its first tick
    await clock.run_to(52.6)
    task.cancel()
    assert seen == pytest.approx([50.0 + 0.25 * k for k in range(11)])
    assert [b.loop for b in told] == ["planner.control", "planner.control"]
    first, second = told
    assert first.times_s == pytest.approx(seen[:5]) and second.times_s == pytest.approx(seen[5:10])
    assert first.times_s[-1] - first.times_s[0] >= BATCH_S


async def test_a_followed_loop_ticks_when_the_recorded_one_did() -> None:
    clock = SimClock(0.0)
    bus = _bus(clock)
    times = LoopTimes(bus, record=False)
    # recorded: on a 0.1 s period, then held up 0.9 s, then late by 0.03 s
    recorded = (100.0, 100.1, 101.0, 101.13, 101.2)
    times.follow([LoopTicks(stamp=101.2, received=101.2, loop="planner.control", times_s=recorded)])
    seen: list[float] = []

    async def loop() -> None:
        async for now in times.ticks("planner.control", 0.1):
            seen.append(round(now, 6))

    task = asyncio.create_task(loop())
    for _ in range(5):
        await asyncio.sleep(0)  # the loop waits for its first tick
    await clock.run_to(0.25)  # the shift is not known yet: its own period
    times.shift_s = -99.0  # replay time = recorded time - 99 s
    await clock.run_to(2.45)
    task.cancel()
    before = [t for t in seen if t < 1.0]
    assert before == pytest.approx([0.0, 0.1, 0.2, 0.3])  # 0.3: already waited for
    followed = [t for t in seen if 1.0 <= t <= 2.2]
    assert followed == pytest.approx([1.0, 1.1, 2.0, 2.13, 2.2])
    after = [t for t in seen if t > 2.2]
    assert after == pytest.approx([2.3, 2.4])  # recorded ticks over: its own period


def test_a_recording_run_cannot_follow() -> None:
    times = LoopTimes(_bus(MonotonicClock()), record=True)
    with pytest.raises(LifecycleError, match="cannot follow"):
        times.follow([])
