from __future__ import annotations

import asyncio
import math

import pytest

from navd.lifecycle.clock import SimClock, ticks
from navd.lifecycle.errors import LifecycleError
from navd.lifecycle.stats import RollingWindow, percentile


async def _settle() -> None:
    for _ in range(5):
        await asyncio.sleep(0)


async def test_sim_clock_wakes_sleepers_in_deadline_order_at_their_deadline() -> None:
    clock = SimClock(start_s=10.0)
    woke: list[tuple[str, float]] = []

    async def sleeper(name: str, seconds: float) -> None:
        await clock.sleep(seconds)
        woke.append((name, clock.now()))

    tasks = [asyncio.create_task(sleeper(n, s)) for n, s in (("c", 3.0), ("a", 1.0), ("b", 2.0))]
    await _settle()
    assert clock.pending_sleepers == 3
    await clock.run_to(11.5)
    assert woke == [("a", 11.0)]
    await clock.run_to(20.0)
    await asyncio.gather(*tasks)
    assert woke == [("a", 11.0), ("b", 12.0), ("c", 13.0)]
    assert clock.now() == 20.0


async def test_sim_clock_jump_wakes_everything_due_at_the_new_time() -> None:
    clock = SimClock(start_s=0.0)
    woke: list[float] = []

    async def sleeper(seconds: float) -> None:
        await clock.sleep(seconds)
        woke.append(clock.now())

    tasks = [asyncio.create_task(sleeper(s)) for s in (1.0, 2.0, 9.0)]
    await _settle()
    clock.advance(5.0)
    await _settle()
    assert woke == [5.0, 5.0]
    assert clock.pending_sleepers == 1
    clock.advance(5.0)
    await asyncio.gather(*tasks)


async def test_run_to_fires_a_periodic_task_once_per_period() -> None:
    clock = SimClock(start_s=0.0)
    fired: list[float] = []

    async def periodic() -> None:
        while True:
            await clock.sleep(0.25)
            fired.append(clock.now())

    task = asyncio.create_task(periodic())
    await _settle()
    await clock.run_to(1.1)
    task.cancel()
    assert fired == [0.25, 0.5, 0.75, 1.0]


def test_sim_clock_never_goes_backwards() -> None:
    clock = SimClock(start_s=5.0)
    with pytest.raises(LifecycleError, match="cannot go backwards"):
        clock.advance(-1.0)
    with pytest.raises(LifecycleError, match=r"from 5.0 s to 4.0 s"):
        clock.advance_to(4.0)


async def test_ticks_follow_a_drift_free_schedule() -> None:
    clock = SimClock(start_s=0.0)
    seen: list[tuple[int, float, int]] = []

    async def consume() -> None:
        async for tick in ticks(clock, 0.1, limit=4):
            seen.append((tick.index, round(tick.scheduled_s, 9), tick.skipped))

    task = asyncio.create_task(consume())
    for _ in range(4):
        await _settle()
        clock.advance(0.1)
    await task
    assert seen == [(0, 0.0, 0), (1, 0.1, 0), (2, 0.2, 0), (3, 0.3, 0)]


async def test_ticks_skip_missed_deadlines_instead_of_bursting() -> None:
    clock = SimClock(start_s=0.0)
    seen: list[tuple[int, float, int]] = []

    async def consume() -> None:
        async for tick in ticks(clock, 1.0, limit=3):
            seen.append((tick.index, tick.scheduled_s, tick.skipped))

    task = asyncio.create_task(consume())
    await _settle()  # tick 0 at t=0
    clock.advance_to(3.5)  # deadline 1.0 fires 2.5 s late: deadlines 2.0 and 3.0 are skipped
    await _settle()
    clock.advance_to(4.0)
    await task
    assert seen == [(0, 0.0, 0), (1, 1.0, 2), (2, 4.0, 0)]


async def test_a_new_period_starts_a_new_grid_at_the_next_deadline() -> None:
    clock = SimClock(start_s=0.0)
    period = [0.5]
    seen: list[float] = []

    async def consume() -> None:
        async for tick in ticks(clock, lambda: period[0], limit=6):
            seen.append(round(tick.scheduled_s, 9))
            if len(seen) == 3:
                period[0] = 0.2  # read after this tick: the next one is 0.2 s after it

    task = asyncio.create_task(consume())
    for _ in range(40):
        await _settle()
        clock.advance(0.05)
    await task
    assert seen == [0.0, 0.5, 1.0, 1.2, 1.4, 1.6]


async def test_a_new_period_after_skipped_ticks_starts_after_the_last_missed_deadline() -> None:
    clock = SimClock(start_s=0.0)
    period = [1.0]
    seen: list[tuple[float, int]] = []

    async def consume() -> None:
        async for tick in ticks(clock, lambda: period[0], limit=4):
            seen.append((round(tick.scheduled_s, 9), tick.skipped))
            period[0] = 0.5 if len(seen) >= 2 else 1.0

    task = asyncio.create_task(consume())
    await _settle()  # tick 0 at t=0
    clock.advance_to(3.5)  # deadline 1.0 fires 2.5 s late: 2.0 and 3.0 are skipped
    await _settle()
    for _ in range(4):
        clock.advance(0.5)
        await _settle()
    await task
    # After the late tick the new 0.5 s grid starts from the last deadline passed (3.0).
    assert seen == [(0.0, 0), (1.0, 2), (3.5, 0), (4.0, 0)]


async def test_ticks_reject_non_positive_period() -> None:
    with pytest.raises(LifecycleError, match="period must be > 0"):
        async for _ in ticks(SimClock(), 0.0):
            pass


def test_rolling_window_keeps_only_recent_samples() -> None:
    window = RollingWindow(4)
    assert window.percentile(50) == 0.0 and window.max() == 0.0
    for value in (100.0, 1.0, 2.0, 3.0, 4.0):
        window.add(value)
    assert len(window) == 4 and window.total == 5
    assert window.max() == 4.0  # the 100 was overwritten
    assert window.percentile(50) == pytest.approx(2.5)


@pytest.mark.parametrize("q", [0.0, 12.5, 50.0, 90.0, 95.0, 99.0, 100.0])
@pytest.mark.parametrize("size", [1, 2, 20, 257])
def test_percentiles_match_numpy(q: float, size: int) -> None:
    import numpy as np

    values = np.random.default_rng(3).exponential(size=size)
    window = RollingWindow(300)
    for value in values:
        window.add(float(value))
    expected = float(np.percentile(values, q))
    assert window.percentile(q) == pytest.approx(expected)
    assert percentile(values.tolist(), q) == pytest.approx(expected)


def test_the_percentile_of_nothing_is_nan() -> None:
    assert math.isnan(percentile([], 50))
