"""Modules and their lifecycle: configure -> activate -> deactivate -> cleanup.

A module subclasses ``Module`` and overrides the hooks it needs. The ``ModuleManager`` starts
modules in the order given (configure all, then activate all) and stops them in reverse
order (deactivate all, then clean up all), each transition bounded by a timeout that raises
``ModuleTimeoutError`` naming the module and the transition that hung. A module talks to the
rest of the daemon only through its ``ModuleContext``: subscribe, publish, submit heavy jobs,
spawn background tasks, and hold its settings (``ctx.settings``: derived from the config by
its room's settings module, swapped whole on a change; see ``navd.lifecycle.settings``).
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable, Coroutine, Sequence
from enum import StrEnum
from typing import Any, TypeVar

from structlog.typing import FilteringBoundLogger

from navd.config import NavdConfig
from navd.lifecycle.bus import Bus, Handler
from navd.lifecycle.clock import Clock, ticks
from navd.lifecycle.errors import ModuleStateError, ModuleTimeoutError
from navd.lifecycle.line_counts import LineCounts
from navd.lifecycle.loop_times import LoopTimes
from navd.lifecycle.messages import ConfigApplied, Message
from navd.lifecycle.settings import Derive, Live
from navd.lifecycle.workers import Job, WorkerPool
from navd.logs import get_logger

__all__ = ["Module", "ModuleContext", "ModuleManager", "ModuleState"]

M = TypeVar("M", bound=Message)
S = TypeVar("S")
_log = get_logger("lifecycle.modules")


class ModuleState(StrEnum):
    """Where a module is in its lifecycle (the Nav2 lifecycle states)."""

    UNCONFIGURED = "unconfigured"
    INACTIVE = "inactive"
    ACTIVE = "active"
    FINALIZED = "finalized"
    ERROR = "error"


class ModuleContext:
    """What a module may use: the bus, the clock, the workers, its settings and the line
    counters drivers keep per device (``line_counts``, for a simulated clock).

    Everything done through the context is attributed to the module (handler failures,
    worker slots, background tasks).
    """

    def __init__(
        self,
        name: str,
        *,
        bus: Bus,
        clock: Clock,
        workers: WorkerPool,
        config: Callable[[], NavdConfig],
        line_counts: LineCounts | None = None,
        prepare_kernels: Callable[[], None] | None = None,
        loop_times: LoopTimes | None = None,
    ) -> None:
        self.name = name
        self._loop_times = loop_times
        self._prepare_kernels = prepare_kernels
        self.bus = bus
        self.clock = clock
        self.workers = workers
        self.line_counts = line_counts if line_counts is not None else LineCounts()
        self.log: FilteringBoundLogger = get_logger(name)
        self._config = config
        self._tasks: set[asyncio.Task[None]] = set()
        self._live: list[Live[Any]] = []
        # Settings are swapped before any handler of the module sees the ConfigApplied, and a
        # failing on_change counts against this module.
        bus.subscribe(ConfigApplied, self._on_config_applied, module=name)

    def settings(
        self, derive: Derive[S], on_change: Callable[[S, S], None] | None = None
    ) -> Live[S]:
        """Hold the settings ``derive`` takes from the config in force (a room's settings
        function); when a config change alters them, ``on_change(old, new)`` runs on the
        event loop and the holder is swapped whole."""
        live = Live(derive, self._config(), on_change)
        self._live.append(live)
        return live

    @property
    def holders(self) -> tuple[Live[Any], ...]:
        """Every settings holder of the module."""
        return tuple(self._live)

    def apply_config(self, config: NavdConfig) -> list[str]:
        """Re-derive every settings holder of the module from ``config``; returns what the
        swapped ones hold (their types' names).

        Raises:
            Exception: the first ``on_change`` that failed, once every holder was tried
                (the failed ones keep their old value).
        """
        swapped: list[str] = []
        errors: list[Exception] = []
        for live in self._live:
            try:
                if live.update(config):
                    swapped.append(live.name)
            except Exception as err:  # every holder gets its turn; the first error is raised
                errors.append(err)
        if errors:
            raise errors[0]
        return swapped

    def _on_config_applied(self, applied: ConfigApplied) -> None:
        swapped = self.apply_config(applied.config)
        if swapped:
            self.log.info("settings_swapped", request_id=applied.request_id, settings=swapped)

    def subscribe(self, message_type: type[M], handler: Handler[M]) -> None:
        """Call the cheap ``handler`` on the event loop for every ``message_type``."""
        self.bus.subscribe(message_type, handler, module=self.name)

    def publish(self, message: Message) -> None:
        """Publish a message to every subscriber."""
        self.bus.publish(message)

    def submit(self, slot: str, job: Job) -> None:
        """Run a heavy job in a worker thread; latest wins within ``slot``."""
        self.workers.submit(slot, job, module=self.name)

    def warm_up(
        self, job: Callable[[], None], *, name: str, then: Callable[[], None] | None = None
    ) -> None:
        """Compile (or load from the cache) this module's kernels in a thread of their own,
        then call ``then()`` on the event loop: what the set-up changes in the module (a
        filter built) takes effect there, at a moment a recording keeps and a replay
        follows (``WorkerPool.run_detached``).

        A real thread on either clock: compiling has no effect on what the kernels compute,
        so it cannot change a simulated run, and it never holds up the event loop (on
        simulated time the first lockstep step waits for it instead, see ``Lockstep``).
        The daemon's kernel preparation (a cold cache filled by a child process) runs first.
        """
        prepare = self._prepare_kernels
        if prepare is None:
            run = job
        else:

            def run() -> None:
                prepare()
                job()

        self.workers.run_detached(run, name=f"{self.name}-{name}", module=self.name, then=then)

    def spawn(self, coro: Coroutine[Any, Any, None], *, name: str) -> asyncio.Task[None]:
        """Run a background task until the module is deactivated.

        A task that raises is reported to supervision as a failure of this module.
        """
        task = asyncio.get_running_loop().create_task(coro, name=f"{self.name}:{name}")
        self._tasks.add(task)
        task.add_done_callback(self._task_done)
        return task

    def every(
        self,
        period_s: float | Callable[[], float],
        callback: Callable[[float], None],
        *,
        name: str,
    ) -> None:
        """Call the cheap ``callback(now)`` every ``period_s`` [s] until deactivation.

        A function for the period (reading a settings holder) is read after each tick, so a
        settings change takes effect from the next deadline on. Deadlines do not drift; ticks
        missed while the loop was busy are skipped. A callback that raises is reported to
        supervision and the ticks stop.
        """

        async def run() -> None:
            if self._loop_times is None:
                async for _ in ticks(self.clock, period_s):
                    callback(self.clock.now())
            else:  # told on a real run, as recorded in a replay
                async for now in self._loop_times.ticks(f"{self.name}.{name}", period_s):
                    callback(now)

        self.spawn(run(), name=name)

    async def cancel_tasks(self, timeout_s: float) -> None:
        """Cancel the module's background tasks and wait up to ``timeout_s`` [s] for them."""
        tasks = list(self._tasks)
        for task in tasks:
            task.cancel()
        if tasks:
            await asyncio.wait(tasks, timeout=timeout_s)

    def _task_done(self, task: asyncio.Task[None]) -> None:
        self._tasks.discard(task)
        if task.cancelled():
            return
        error = task.exception()
        if error is not None:
            self.bus.report_failure(self.name, {"task": task.get_name()}, error)


class Module:
    """Base of every module; override the hooks you need.

    Args:
        name: unique name, used in logs, status and failure counts.
    """

    def __init__(self, name: str) -> None:
        self.name = name

    async def on_configure(self, ctx: ModuleContext) -> None:
        """Read config, allocate, subscribe handlers. No I/O that can hang here if avoidable."""

    async def on_activate(self) -> None:
        """Open devices and sockets, start background tasks."""

    async def on_deactivate(self) -> None:
        """Stop acting: close devices and sockets. Background tasks are cancelled after."""

    async def on_cleanup(self) -> None:
        """Release what on_configure allocated."""

    def settings_in_use(self) -> tuple[object, ...]:
        """The settings values the module's parts hold now, each one its holders derive
        (read back from the parts, not from the holders, so a part that missed a change
        shows)."""
        return ()


class ModuleManager:
    """Starts and stops modules in a defined order, with timeouts.

    Args:
        modules: in start order; stopped in reverse.
        make_context: builds a module's context.
        timeout_s: [s] longest any one transition may take.
    """

    def __init__(
        self,
        modules: Sequence[Module],
        make_context: Callable[[str], ModuleContext],
        timeout_s: float,
    ) -> None:
        names = [m.name for m in modules]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ModuleStateError(f"module names must be unique; repeated: {duplicates}")
        self.modules = list(modules)
        self.timeout_s = timeout_s
        self._make_context = make_context
        self.states = {m.name: ModuleState.UNCONFIGURED for m in modules}
        self.contexts: dict[str, ModuleContext] = {}

    async def start(self) -> None:
        """Configure every module, then activate every module, in order.

        If any transition fails or hangs, the modules already started are stopped again and
        the error is raised.

        Raises:
            ModuleTimeoutError: a transition hung.
            Exception: whatever a module's hook raised.
        """
        try:
            for module in self.modules:
                ctx = self._make_context(module.name)
                self.contexts[module.name] = ctx
                await self._transition(
                    module,
                    "configure",
                    module.on_configure(ctx),
                    ModuleState.UNCONFIGURED,
                    ModuleState.INACTIVE,
                )
            for module in self.modules:
                await self._transition(
                    module,
                    "activate",
                    module.on_activate(),
                    ModuleState.INACTIVE,
                    ModuleState.ACTIVE,
                )
        except BaseException:
            await self.stop()
            raise

    async def stop(self) -> list[Exception]:
        """Deactivate, then clean up, every module in reverse order.

        Stopping never gives up half-way: a module that fails or hangs is logged, marked
        ERROR, and the others are still stopped.

        Returns:
            The errors met, in order (empty on a clean stop).
        """
        errors: list[Exception] = []
        for module in reversed(self.modules):
            if self.states[module.name] is ModuleState.ACTIVE:
                await self._stop_step(
                    module, "deactivate", module.on_deactivate(), ModuleState.INACTIVE, errors
                )
                ctx = self.contexts[module.name]
                ctx.bus.unsubscribe_module(module.name)
                await ctx.cancel_tasks(self.timeout_s)
        for module in reversed(self.modules):
            if self.states[module.name] is ModuleState.INACTIVE:
                await self._stop_step(
                    module, "cleanup", module.on_cleanup(), ModuleState.FINALIZED, errors
                )
        return errors

    async def _stop_step(
        self,
        module: Module,
        transition: str,
        hook: Coroutine[Any, Any, None],
        target: ModuleState,
        errors: list[Exception],
    ) -> None:
        try:
            await self._transition(module, transition, hook, self.states[module.name], target)
        except Exception as err:  # keep stopping the others; the error is returned
            _log.error(
                "module_stop_failed", module=module.name, transition=transition, error=str(err)
            )
            errors.append(err)

    async def _transition(
        self,
        module: Module,
        transition: str,
        hook: Awaitable[None],
        expected: ModuleState,
        target: ModuleState,
    ) -> None:
        state = self.states[module.name]
        if state is not expected:
            if asyncio.iscoroutine(hook):
                hook.close()
            raise ModuleStateError(
                f"module {module.name!r} cannot {transition} from state {state.value}"
            )
        try:
            await asyncio.wait_for(hook, timeout=self.timeout_s)
        except TimeoutError as err:
            self.states[module.name] = ModuleState.ERROR
            raise ModuleTimeoutError(module.name, transition, self.timeout_s) from err
        except BaseException:
            self.states[module.name] = ModuleState.ERROR
            raise
        self.states[module.name] = target
        _log.debug(
            "module_transition", module=module.name, transition=transition, state=target.value
        )
