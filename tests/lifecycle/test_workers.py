from __future__ import annotations

import asyncio
import math
import threading

import pytest

from navd.lifecycle import workers
from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import Clock, MonotonicClock, SimClock
from navd.lifecycle.errors import LifecycleError
from navd.lifecycle.line_counts import LineCounts
from navd.lifecycle.lockstep import Lockstep
from navd.lifecycle.messages import Message, VelocityCommand, WorkerJob
from navd.lifecycle.supervision import Supervisor
from navd.lifecycle.work_script import WorkScript
from navd.lifecycle.workers import WorkerPool
from tests.conftest import velocity


async def _until(predicate: object, timeout_s: float = 5.0) -> None:
    """Let the loop run until ``predicate()`` holds (results arrive from threads)."""

    async def wait() -> None:
        while not predicate():  # type: ignore[operator]
            await asyncio.sleep(0.001)

    await asyncio.wait_for(wait(), timeout_s)


async def test_latest_wins_replaces_the_waiting_job_and_counts_drops(bus: Bus) -> None:
    results: list[float] = []
    bus.subscribe(VelocityCommand, lambda m: results.append(m.linear_mps), module="rec")
    pool = WorkerPool(bus, threads=2)
    gate = threading.Event()
    ran: list[float] = []

    def job(value: float, wait: bool = False) -> VelocityCommand:
        if wait:
            assert gate.wait(5.0)
        ran.append(value)
        return velocity(value)

    pool.submit("match", lambda: job(1.0, wait=True), module="slam")
    for value in (2.0, 3.0, 4.0):  # 2 and 3 are replaced while 1 runs
        pool.submit("match", lambda v=value: job(v), module="slam")  # type: ignore[misc]
    gate.set()
    await _until(lambda: len(results) == 2 and not pool.busy())
    assert ran == [1.0, 4.0]
    assert results == [1.0, 4.0]
    (stats,) = pool.stats()
    assert (stats.slot, stats.submitted, stats.completed, stats.dropped, stats.failed) == (
        "match",
        4,
        2,
        2,
        0,
    )
    pool.close()


async def test_slots_run_independently(bus: Bus) -> None:
    done: list[str] = []
    pool = WorkerPool(bus, threads=2)
    gate = threading.Event()

    def blocked() -> None:
        assert gate.wait(5.0)
        done.append("a")

    pool.submit("a", blocked, module="m")
    pool.submit("b", lambda: done.append("b") and None, module="m")  # type: ignore[func-returns-value]
    await _until(lambda: done == ["b"])
    gate.set()
    await _until(lambda: not pool.busy())
    assert done == ["b", "a"]
    pool.close()


async def test_failing_job_is_reported_to_supervision_and_slot_keeps_working(bus: Bus) -> None:
    pool = WorkerPool(bus, threads=1)
    out: list[Message] = []
    bus.subscribe(VelocityCommand, out.append, module="rec")

    def bad() -> None:
        raise ArithmeticError("singular matrix")

    pool.submit("plan", bad, module="planner")
    await _until(lambda: not pool.busy())
    pool.submit("plan", lambda: velocity(0.5), module="planner")
    await _until(lambda: len(out) == 1)
    assert bus.supervisor.record("planner").failures == 1
    assert "singular matrix" in bus.supervisor.record("planner").last_error
    assert pool.stats()[0].failed == 1 and pool.stats()[0].completed == 1
    pool.close()


async def test_slot_belongs_to_one_module(bus: Bus) -> None:
    pool = WorkerPool(bus, threads=1)
    pool.submit("scan", lambda: None, module="slam")
    with pytest.raises(LifecycleError, match="slot 'scan' belongs to module 'slam', not 'planner'"):
        pool.submit("scan", lambda: None, module="planner")
    pool.close()


async def test_closed_pool_refuses_jobs(bus: Bus) -> None:
    pool = WorkerPool(bus, threads=1)
    pool.close()
    with pytest.raises(LifecycleError, match="worker pool is closed"):
        pool.submit("scan", lambda: None, module="slam")


async def test_wait_idle_returns_once_every_job_and_detached_setup_is_done(bus: Bus) -> None:
    pool = WorkerPool(bus, threads=2)
    await asyncio.wait_for(pool.wait_idle(), 1.0)  # nothing running: at once
    job_gate, setup_gate = threading.Event(), threading.Event()
    pool.submit("plan", lambda: (job_gate.wait(5.0), None)[1], module="planner")

    def setup() -> None:
        setup_gate.wait(5.0)

    pool.run_detached(setup, name="set-up", module="estimation")
    waiter = asyncio.create_task(pool.wait_idle())
    job_gate.set()
    await _until(lambda: pool.stats()[0].completed == 1)
    await asyncio.sleep(0.01)
    assert pool.busy() and not waiter.done()  # the detached set-up still runs
    setup_gate.set()
    await asyncio.wait_for(waiter, 5.0)
    assert not pool.busy()
    pool.close()


async def test_each_set_up_drops_the_compilers_code_as_it_ends(
    bus: Bus, monkeypatch: pytest.MonkeyPatch
) -> None:
    released: list[str] = []
    monkeypatch.setattr(
        workers, "release_compiler_code", lambda: released.append(threading.current_thread().name)
    )
    pool = WorkerPool(bus, threads=1)
    first_gate, second_gate = threading.Event(), threading.Event()
    pool.run_detached(lambda: first_gate.wait(5.0), name="first-setup", module="slam")
    pool.run_detached(lambda: second_gate.wait(5.0), name="second-setup", module="planner")
    first_gate.set()
    await _until(lambda: released == ["first-setup"])  # the other still runs: dropped anyway
    second_gate.set()
    await asyncio.wait_for(pool.wait_idle(), 5.0)
    assert released == ["first-setup", "second-setup"]
    pool.close()


async def test_a_detached_job_that_raises_is_reported_and_ends_its_busy_time(bus: Bus) -> None:
    pool = WorkerPool(bus, threads=1)

    def broken() -> None:
        raise RuntimeError("set-up failed")

    pool.run_detached(broken, name="broken-setup", module="estimation")
    await asyncio.wait_for(pool.wait_idle(), 5.0)
    assert not pool.busy()
    record = bus.supervisor.record("estimation")
    assert record.failures == 1 and "set-up failed" in record.last_error
    pool.close()


async def test_inline_jobs_run_on_the_loop_in_start_order(bus: Bus) -> None:
    results: list[float] = []
    bus.subscribe(VelocityCommand, lambda m: results.append(m.linear_mps), module="rec")
    pool = WorkerPool(bus, threads=2, inline=True)
    threads: list[str] = []

    def job(value: float) -> VelocityCommand:
        threads.append(threading.current_thread().name)
        return velocity(value)

    pool.submit("b", lambda: job(1.0), module="planner")
    pool.submit("a", lambda: job(2.0), module="slam")
    pool.submit("b", lambda: job(3.0), module="planner")  # waits for the first "b"
    assert pool.busy() and results == []  # started, not yet run: the caller goes on first
    await asyncio.wait_for(pool.wait_idle(), 5.0)
    assert results == [1.0, 2.0, 3.0]
    assert set(threads) == {threading.current_thread().name}
    pool.close()


def _bus(clock: Clock) -> Bus:
    supervisor = Supervisor(max_failures=3, window_s=10.0)
    return Bus(clock, supervisor, handler_budget_s=10.0, max_cascade=100)


async def test_each_job_says_when_it_was_submitted_begun_and_published_or_dropped() -> None:
    bus = _bus(MonotonicClock())  # real time: the threads take some
    timings: list[WorkerJob] = []
    bus.subscribe(WorkerJob, timings.append, module="rec")
    pool = WorkerPool(bus, threads=1)
    gate = threading.Event()
    pool.submit("match", lambda: (gate.wait(5.0), None)[1], module="slam")
    pool.submit("match", lambda: None, module="slam")  # waits, then is replaced
    pool.submit("match", lambda: velocity(4.0), module="slam")
    gate.set()
    await _until(lambda: len(timings) == 3 and not pool.busy())
    pool.close()
    dropped = [t for t in timings if t.outcome == "dropped"]
    done = [t for t in timings if t.outcome == "done"]
    assert len(dropped) == 1 and math.isnan(dropped[0].finished_s) and len(done) == 2
    first, last = sorted(done, key=lambda t: t.submitted_s)
    assert first.submitted_s <= first.started_s <= first.finished_s
    # the last one waited for the first to finish before it began
    assert last.submitted_s < first.finished_s <= last.started_s <= last.finished_s


async def test_following_a_recorded_run_a_job_is_dropped_or_published_after_its_delays() -> None:
    clock = SimClock(100.0)
    bus = _bus(clock)
    published: list[tuple[float, float]] = []
    bus.subscribe(
        VelocityCommand, lambda m: published.append((clock.now(), m.linear_mps)), module="rec"
    )
    pool = WorkerPool(bus, threads=1, inline=True)

    def timing(submitted: float, started: float, finished: float, outcome: str) -> WorkerJob:
        return WorkerJob(
            stamp=submitted, received=submitted, slot="match", submitted_s=submitted,
            started_s=started, finished_s=finished, outcome=outcome,
        )  # fmt: skip

    recorded = [  # a real run's: submitted at 10.0, 10.1 and 10.15 (its clock)
        timing(10.0, 10.02, 10.3, "done"),
        timing(10.1, math.nan, math.nan, "dropped"),
        timing(10.15, 10.3, 10.5, "done"),
    ]
    script = WorkScript(recorded)
    script.shift_s = 90.0  # the replay's clock is 90 s ahead of the recorded one
    pool.follow(script)
    ran: list[float] = []

    def job(value: float) -> VelocityCommand:
        ran.append(clock.now())
        return velocity(value)

    lockstep = Lockstep(clock, pool, LineCounts())
    pool.submit("match", lambda: job(1.0), module="slam")
    await lockstep.step_to(100.1, {}, 5.0)
    pool.submit("match", lambda: job(2.0), module="slam")  # dropped, as recorded
    await lockstep.step_to(100.15, {}, 5.0)
    pool.submit("match", lambda: job(3.0), module="slam")
    await lockstep.step_to(100.2, {}, 5.0)
    pool.submit("other", lambda: job(9.0), module="slam")  # never recorded: at once
    await lockstep.step_to(101.0, {}, 5.0)
    pool.close()
    assert published == [
        (100.2, 9.0),
        (pytest.approx(100.3), 1.0),
        (pytest.approx(100.5), 3.0),
    ]
    assert ran == [pytest.approx(100.02), pytest.approx(100.2), pytest.approx(100.3)]
    assert (script.followed, script.unmatched, script.missed) == (3, 1, 0)
