from __future__ import annotations

import asyncio

import pytest

from navd.config import NavdConfig
from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import SimClock
from navd.lifecycle.errors import ModuleStateError, ModuleTimeoutError
from navd.lifecycle.module import Module, ModuleContext, ModuleManager, ModuleState
from navd.lifecycle.workers import WorkerPool


class Recording(Module):
    """Appends every transition to a shared journal; can hang or fail on one of them."""

    def __init__(self, name: str, journal: list[str], hang: str = "", fail: str = "") -> None:
        super().__init__(name)
        self.journal = journal
        self.hang = hang
        self.fail = fail

    async def _step(self, transition: str) -> None:
        self.journal.append(f"{transition} {self.name}")
        if transition == self.hang:
            await asyncio.sleep(3600)
        if transition == self.fail:
            raise RuntimeError(f"{self.name} cannot {transition}")

    async def on_configure(self, ctx: ModuleContext) -> None:
        await self._step("configure")

    async def on_activate(self) -> None:
        await self._step("activate")

    async def on_deactivate(self) -> None:
        await self._step("deactivate")

    async def on_cleanup(self) -> None:
        await self._step("cleanup")


def _manager(bus: Bus, modules: list[Module], timeout_s: float = 0.05) -> ModuleManager:
    workers = WorkerPool(bus, threads=1)
    config = NavdConfig()
    return ModuleManager(
        modules,
        lambda name: ModuleContext(
            name, bus=bus, clock=bus.clock, workers=workers, config=lambda: config
        ),
        timeout_s,
    )


async def test_start_configures_all_then_activates_in_order_and_stop_reverses(bus: Bus) -> None:
    journal: list[str] = []
    manager = _manager(bus, [Recording(n, journal) for n in ("tcp", "slam", "planner")])
    await manager.start()
    assert journal == [
        "configure tcp",
        "configure slam",
        "configure planner",
        "activate tcp",
        "activate slam",
        "activate planner",
    ]
    assert set(manager.states.values()) == {ModuleState.ACTIVE}
    journal.clear()
    assert await manager.stop() == []
    assert journal == [
        "deactivate planner",
        "deactivate slam",
        "deactivate tcp",
        "cleanup planner",
        "cleanup slam",
        "cleanup tcp",
    ]
    assert set(manager.states.values()) == {ModuleState.FINALIZED}


async def test_hung_activate_raises_named_timeout_and_stops_started_modules(bus: Bus) -> None:
    journal: list[str] = []
    modules = [
        Recording("tcp", journal),
        Recording("slam", journal, hang="activate"),
        Recording("planner", journal),
    ]
    manager = _manager(bus, modules)
    with pytest.raises(
        ModuleTimeoutError,
        match=r"module 'slam' did not finish activate within "
        r"0.05 s",
    ):
        await manager.start()
    assert "activate planner" not in journal
    assert journal[-3:] == ["deactivate tcp", "cleanup planner", "cleanup tcp"]
    assert manager.states == {
        "tcp": ModuleState.FINALIZED,
        "slam": ModuleState.ERROR,
        "planner": ModuleState.FINALIZED,
    }


async def test_failing_configure_propagates_after_cleaning_up(bus: Bus) -> None:
    journal: list[str] = []
    manager = _manager(bus, [Recording("a", journal), Recording("b", journal, fail="configure")])
    with pytest.raises(RuntimeError, match="b cannot configure"):
        await manager.start()
    assert journal == ["configure a", "configure b", "cleanup a"]


async def test_stop_continues_past_a_hung_module_and_reports_it(bus: Bus) -> None:
    journal: list[str] = []
    modules = [
        Recording("a", journal),
        Recording("b", journal, hang="deactivate"),
        Recording("c", journal),
    ]
    manager = _manager(bus, modules)
    await manager.start()
    journal.clear()
    errors = await manager.stop()
    assert [str(e) for e in errors] == [
        "module 'b' did not finish deactivate within 0.05 s; it is hung "
        "(raise lifecycle.transition_timeout_s if it is only slow)"
    ]
    assert journal == ["deactivate c", "deactivate b", "deactivate a", "cleanup c", "cleanup a"]
    assert manager.states["b"] is ModuleState.ERROR


def test_module_names_must_be_unique(bus: Bus) -> None:
    with pytest.raises(ModuleStateError, match=r"repeated: \['x'\]"):
        _manager(bus, [Module("x"), Module("y"), Module("x")])


async def test_spawned_task_failure_is_supervised_and_tasks_end_on_deactivate(
    bus: Bus, clock: SimClock
) -> None:
    started = asyncio.Event()

    class Spawner(Module):
        async def on_configure(self, ctx: ModuleContext) -> None:
            self.ctx = ctx

        async def on_activate(self) -> None:
            self.ctx.spawn(self._crash(), name="crash")
            self.forever = self.ctx.spawn(self._forever(), name="forever")

        async def _crash(self) -> None:
            raise ConnectionError("port vanished")

        async def _forever(self) -> None:
            started.set()
            await asyncio.sleep(3600)

    module = Spawner("driver")
    manager = _manager(bus, [module])
    await manager.start()
    await started.wait()
    await asyncio.sleep(0)
    assert bus.supervisor.record("driver").last_error == "ConnectionError: port vanished"
    await manager.stop()
    assert module.forever.cancelled()


async def test_every_calls_back_on_time_until_deactivated_and_reports_a_crash(
    bus: Bus, clock: SimClock
) -> None:
    calls: list[float] = []

    class Ticker(Module):
        async def on_configure(self, ctx: ModuleContext) -> None:
            self.ctx = ctx

        async def on_activate(self) -> None:
            self.ctx.every(0.1, calls.append, name="tick")
            self.ctx.every(0.25, self._crash, name="crash")

        def _crash(self, now: float) -> None:
            raise ValueError(f"bad tick at {now:.2f}")

    manager = _manager(bus, [Ticker("ticker")])
    start = clock.now()
    await manager.start()
    await clock.run_to(start + 0.35)
    assert [t - start for t in calls] == pytest.approx([0.0, 0.1, 0.2, 0.3])
    assert bus.supervisor.record("ticker").last_error == f"ValueError: bad tick at {start:.2f}"
    await manager.stop()
    await clock.run_to(clock.now() + 1.0)
    assert len(calls) == 4
