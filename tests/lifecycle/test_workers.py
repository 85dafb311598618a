from __future__ import annotations

import asyncio
import threading

import pytest

from navd.lifecycle import workers
from navd.lifecycle.bus import Bus
from navd.lifecycle.errors import LifecycleError
from navd.lifecycle.messages import Message, VelocityCommand
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
