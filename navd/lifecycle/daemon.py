"""The daemon: one event loop that owns the bus, the workers, the modules and the status.

Start-up: internal probes start, modules are configured then activated in order, and a
``ready`` line is logged. Shutdown (SIGTERM, SIGINT, or ``request_shutdown``): a zero
VelocityCommand is published first, then modules stop in reverse order, and ``run`` returns.
SIGHUP reloads the config file (applied whole or rejected whole).
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from navd import __version__
from navd.config import NavdConfig, redacted
from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import Clock, MonotonicClock, SimClock
from navd.lifecycle.config_service import ConfigService
from navd.lifecycle.daemon_settings import LifecycleSettings, LoggingSettings
from navd.lifecycle.file_limit import raise_file_limit
from navd.lifecycle.lag import LoopLagMonitor
from navd.lifecycle.line_counts import LineCounts
from navd.lifecycle.loop_times import LoopTimes
from navd.lifecycle.messages import (
    ConfigApplied,
    DaemonStatus,
    ModuleHealth,
    SafeStopCleared,
    VelocityCommand,
)
from navd.lifecycle.module import Module, ModuleContext, ModuleManager
from navd.lifecycle.scheduling import request_slice, thread_slice_s
from navd.lifecycle.sdnotify import SystemdNotifier
from navd.lifecycle.settings import Live
from navd.lifecycle.state_view import StateView
from navd.lifecycle.supervision import Supervisor
from navd.lifecycle.workers import WorkerPool
from navd.logs import current_level, get_logger, set_level

__all__ = ["Daemon"]

_log = get_logger("lifecycle")


class Daemon:
    """navd's event loop and everything it owns.

    Args:
        config: the config at start-up.
        modules: in start order (stopped in reverse).
        clock: the time source; by default real monotonic time, or a SimClock that a
            simulator moves when ``lifecycle.clock`` is "simulated".
        config_path: the file SIGHUP reloads; None disables reloading.
        handle_signals: install SIGTERM/SIGINT/SIGHUP handlers (off in tests that share a loop).
        notifier: systemd notifications; by default from the environment (inactive without
            NOTIFY_SOCKET).
        prepare_kernels: called (in a warm-up thread, possibly several at once) before any
            module's warm-up loads its kernels: ``navd run`` fills a cold numba cache there in
            a child process. None: nothing to prepare.
    """

    MODULE = "lifecycle"

    def __init__(
        self,
        config: NavdConfig,
        modules: Sequence[Module] = (),
        *,
        clock: Clock | None = None,
        config_path: Path | None = None,
        handle_signals: bool = True,
        notifier: SystemdNotifier | None = None,
        prepare_kernels: Callable[[], None] | None = None,
    ) -> None:
        self._prepare_kernels = prepare_kernels
        lc = config.lifecycle
        if clock is None:
            clock = SimClock() if lc.clock == "simulated" else MonotonicClock()
        self.clock: Clock = clock
        self.line_counts = LineCounts(defer=lc.clock == "simulated")
        self.supervisor = Supervisor(lc.max_handler_failures, lc.failure_window_s)
        self.bus = Bus(
            self.clock,
            self.supervisor,
            handler_budget_s=lc.handler_budget_ms / 1e3,
            max_cascade=lc.max_dispatch_cascade,
        )
        self.config_service = ConfigService(self.bus, self.clock, config)
        # the robot as the outside is told it, heard before any module's handlers
        self.state_view = StateView(self.bus, self.clock)
        self.workers = WorkerPool(self.bus, lc.worker_threads, inline=lc.clock == "simulated")
        # the periodic loops' ticks: told on real time (a recording keeps them), followed in a
        # replay (``navd.viz.playback``)
        self.loop_times = LoopTimes(self.bus, record=lc.clock != "simulated")
        self.lag = LoopLagMonitor(lc.lag_sample_period_s, lc.lag_window)
        self.manager = ModuleManager(modules, self._context, lc.transition_timeout_s)
        self.config_path = config_path
        self.handle_signals = handle_signals
        self.ready = asyncio.Event()
        self._shutdown = asyncio.Event()
        self._shutdown_reason = ""
        self._started_s = self.clock.now()
        self.notifier = notifier if notifier is not None else SystemdNotifier()
        self.lifecycle = Live(LifecycleSettings.from_config, config, self._lifecycle_changed)
        self.logging = Live(LoggingSettings.from_config, config, self._logging_changed)
        self.bus.subscribe(ConfigApplied, self._on_config_applied, module=self.MODULE)

    @property
    def config(self) -> NavdConfig:
        """The config in force."""
        return self.config_service.current

    def request_shutdown(self, reason: str) -> None:
        """Ask the daemon to stop; ``run`` returns once every module has stopped."""
        if not self._shutdown.is_set():
            self._shutdown_reason = reason
            _log.info("shutdown_requested", reason=reason)
            self.notifier.notify("STOPPING=1", f"STATUS=stopping: {reason}")
            self._shutdown.set()

    def reload_config(self) -> bool:
        """Reload ``config_path`` through the same validation as runtime changes."""
        if self.config_path is None:
            _log.warning("reload_ignored", reason="the daemon was started without a config file")
            return False
        self.notifier.notify("RELOADING=1")
        applied = self.config_service.reload(self.config_path, request_id="sighup")
        self.notifier.notify(
            "READY=1", f"STATUS=config reload {'applied' if applied else 'rejected'}"
        )
        return applied

    def status(self) -> DaemonStatus:
        """A snapshot of the daemon's health."""
        now = self.clock.now()
        p50, p99, worst = self.lag.snapshot_ms()
        faulted = self.supervisor.faulted()
        modules = tuple(
            ModuleHealth(
                name=m.name,
                state=self.manager.states[m.name].value,
                handler_failures=self.supervisor.record(m.name).failures,
                slow_handlers=self.supervisor.record(m.name).slow_handlers,
                faulted=m.name in faulted,
            )
            for m in self.manager.modules
        )
        reasons = tuple(
            f"module {name!r} faulted: {rec.last_error}" for name, rec in faulted.items()
        )
        return DaemonStatus(
            stamp=now,
            received=now,
            uptime_s=now - self._started_s,
            loop_lag_p50_ms=p50,
            loop_lag_p99_ms=p99,
            loop_lag_max_ms=worst,
            modules=modules,
            workers=self.workers.stats(),
            safe_stop_reasons=reasons,
            messages_dispatched=self.bus.dispatched,
        )

    async def run(self) -> None:
        """Start, run until shutdown is requested, and stop cleanly.

        Raises:
            ModuleTimeoutError: a module hung while starting (the others were stopped).
            Exception: whatever a module raised while starting.
        """
        loop = asyncio.get_running_loop()
        # Set for the process while the daemon runs (and given back after, for a process
        # that runs daemons in turn, such as the tests).
        switch_interval_s = sys.getswitchinterval()
        lifecycle = self.config_service.current.lifecycle
        sys.setswitchinterval(lifecycle.switch_interval_ms / 1e3)
        slice_ms = lifecycle.loop_slice_ms
        # this thread runs the event loop: a short slice has it run soon after it wakes
        slice_before_s = thread_slice_s()
        sliced = slice_ms > 0.0 and request_slice(slice_ms / 1e3)
        self._install_signals(loop)
        set_level(self.logging.value.level)  # the level in force is the config's, from here on
        self._started_s = self.clock.now()
        files_before, files = raise_file_limit()
        probes = [
            loop.create_task(self.lag.run(), name="lag-probe"),
            loop.create_task(self._status_loop(), name="status"),
        ]
        _log.info(
            "starting",
            version=__version__,
            loop_slice_ms=slice_ms if sliced else None,  # None: the kernel's default
            modules=[m.name for m in self.manager.modules],
            open_files_limit=files,
            open_files_limit_was=files_before if files_before != files else None,
            config=redacted(self.config),
        )
        try:
            await self.manager.start()
            # start-up objects (modules, config, imported libraries) live as long as the
            # process: move them out of the collector's way, so a full collection scans only
            # what was allocated since, and never stalls the loop for milliseconds
            gc.collect()
            gc.freeze()
            self.ready.set()
            _log.info("ready", modules=[m.name for m in self.manager.modules])
            self.notifier.notify("READY=1", "STATUS=running")
            if self.notifier.watchdog_period_s is not None:  # armed once we are up
                probes.append(loop.create_task(self._watchdog(), name="watchdog"))
            await self._shutdown.wait()
        finally:
            self._stop_robot(self._shutdown_reason or "start-up failed")
            errors = await self.manager.stop()
            for task in probes:
                task.cancel()
            await asyncio.gather(*probes, return_exceptions=True)
            self.workers.close()
            self._remove_signals(loop)
            self.notifier.close()
            sys.setswitchinterval(switch_interval_s)
            if sliced and slice_before_s is not None:
                request_slice(slice_before_s)
            _log.info("stopped", reason=self._shutdown_reason, stop_errors=len(errors))

    def _context(self, name: str) -> ModuleContext:
        return ModuleContext(
            name,
            bus=self.bus,
            clock=self.clock,
            workers=self.workers,
            config=lambda: self.config_service.current,
            line_counts=self.line_counts,
            prepare_kernels=self._prepare_kernels,
            loop_times=self.loop_times,
        )

    def _stop_robot(self, reason: str) -> None:
        now = self.clock.now()
        _log.info("zero_velocity", reason=reason)
        self.bus.publish(
            VelocityCommand(
                stamp=now, received=now, linear_mps=0.0, angular_radps=0.0, source=self.MODULE
            )
        )

    def settings_in_use(self) -> tuple[object, ...]:
        """The daemon's settings as its parts hold them now (read back from the bus, the
        supervisor, the probe, the module manager and the log configuration)."""
        return (
            LifecycleSettings(
                handler_budget_s=self.bus.handler_budget_s,
                max_cascade=self.bus.max_cascade,
                max_failures=self.supervisor.max_failures,
                failure_window_s=self.supervisor.window_s,
                lag_period_s=self.lag.period_s,
                transition_timeout_s=self.manager.timeout_s,
                status_period_s=self.lifecycle.value.status_period_s,
            ),
            LoggingSettings(current_level(), self.logging.value.status_log_period_s),
        )

    async def _status_loop(self) -> None:
        last_logged = self.clock.now()
        while True:
            await self.clock.sleep(self.lifecycle.value.status_period_s)
            now = self.clock.now()
            for name in self.supervisor.clear_recovered(now):
                _log.info("module_recovered", module=name)
                self.bus.publish(
                    SafeStopCleared(
                        stamp=now, received=now, key=f"fault:{name}", source="supervisor"
                    )
                )
            status = self.status()
            self.bus.publish(status)
            self.notifier.notify(_status_line(status))
            period = self.logging.value.status_log_period_s
            if period > 0 and now - last_logged >= period:
                last_logged = now
                _log.info(
                    "status",
                    uptime_s=round(status.uptime_s, 1),
                    loop_lag_p99_ms=round(status.loop_lag_p99_ms, 3),
                    messages=status.messages_dispatched,
                    safe_stop=list(status.safe_stop_reasons),
                )

    async def _watchdog(self) -> None:
        """Ping systemd's watchdog from the event loop: a stalled loop stops the pings.

        Uses real time on purpose: the watchdog guards the real process, whatever clock
        the daemon runs on.
        """
        assert self.notifier.watchdog_period_s is not None
        period = self.notifier.watchdog_period_s / 2.0
        while True:
            self.notifier.notify("WATCHDOG=1")
            await asyncio.sleep(period)

    def _on_config_applied(self, applied: ConfigApplied) -> None:
        self.lifecycle.update(applied.config)
        self.logging.update(applied.config)

    def _lifecycle_changed(self, _old: LifecycleSettings, new: LifecycleSettings) -> None:
        self.bus.handler_budget_s = new.handler_budget_s
        self.bus.max_cascade = new.max_cascade
        self.supervisor.max_failures = new.max_failures
        self.supervisor.window_s = new.failure_window_s
        self.lag.period_s = new.lag_period_s
        self.manager.timeout_s = new.transition_timeout_s

    def _logging_changed(self, old: LoggingSettings, new: LoggingSettings) -> None:
        if new.level != old.level:
            set_level(new.level)

    def _install_signals(self, loop: asyncio.AbstractEventLoop) -> None:
        if not self.handle_signals:
            return
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, self.request_shutdown, f"signal {sig.name}")
        loop.add_signal_handler(signal.SIGHUP, self.reload_config)

    def _remove_signals(self, loop: asyncio.AbstractEventLoop) -> None:
        if not self.handle_signals:
            return
        for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
            with contextlib.suppress(ValueError, RuntimeError):
                loop.remove_signal_handler(sig)


def _status_line(status: DaemonStatus) -> str:
    """The one-line STATUS= that ``systemctl status navd`` shows."""
    safety = "; ".join(status.safe_stop_reasons) or "ok"
    return (
        f"STATUS=running {status.uptime_s:.0f} s, loop lag p99 {status.loop_lag_p99_ms:.1f} ms, "
        f"{status.messages_dispatched} messages, safety: {safety}"
    )
