"""The daemon in-process, on simulated time (the real process is tested in tests/e2e)."""

from __future__ import annotations

import asyncio
import sys
import time
from pathlib import Path

import pytest

from navd.config import NavdConfig, dump_toml, parse_config
from navd.lifecycle.clock import SimClock
from navd.lifecycle.daemon import Daemon
from navd.lifecycle.messages import (
    ConfigApplied,
    ConfigChange,
    ConfigRejected,
    DaemonStatus,
    VelocityCommand,
)
from navd.lifecycle.module import Module, ModuleContext
from navd.lifecycle.scheduling import thread_slice_s


async def _settle() -> None:
    for _ in range(10):
        await asyncio.sleep(0)


class Probe(Module):
    """Records what it receives and when it is deactivated."""

    def __init__(self, journal: list[object], fail_on_velocity: bool = False) -> None:
        super().__init__("probe")
        self.journal = journal
        self.fail_on_velocity = fail_on_velocity

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        ctx.subscribe(VelocityCommand, self._on_velocity)
        ctx.subscribe(DaemonStatus, self.journal.append)
        ctx.subscribe(ConfigApplied, self.journal.append)
        ctx.subscribe(ConfigRejected, self.journal.append)

    def _on_velocity(self, cmd: VelocityCommand) -> None:
        self.journal.append(cmd)
        if self.fail_on_velocity and cmd.source == "test":
            raise RuntimeError("cannot drive")

    async def on_deactivate(self) -> None:
        self.journal.append("deactivated")


@pytest.fixture
def config() -> NavdConfig:
    return parse_config({"lifecycle": {"status_rate_hz": 2.0, "max_handler_failures": 2}})


async def _started(daemon: Daemon) -> asyncio.Task[None]:
    task = asyncio.create_task(daemon.run())
    await asyncio.wait_for(daemon.ready.wait(), 5.0)
    return task


async def test_shutdown_publishes_zero_velocity_before_modules_stop(config: NavdConfig) -> None:
    journal: list[object] = []
    daemon = Daemon(config, [Probe(journal)], clock=SimClock(), handle_signals=False)
    task = await _started(daemon)
    daemon.request_shutdown("test over")
    await asyncio.wait_for(task, 5.0)
    stops = [i for i, m in enumerate(journal) if isinstance(m, VelocityCommand) and m.is_stop]
    assert stops and stops[0] < journal.index("deactivated")
    assert daemon.manager.states["probe"].value == "finalized"


async def test_status_is_published_at_the_configured_rate_on_sim_time(
    config: NavdConfig,
) -> None:
    journal: list[object] = []
    clock = SimClock()
    daemon = Daemon(config, [Probe(journal)], clock=clock, handle_signals=False)
    task = await _started(daemon)
    for _ in range(4):  # 2 s of simulated time at 2 Hz
        await _settle()
        clock.advance(0.5)
    await _settle()
    statuses = [m for m in journal if isinstance(m, DaemonStatus)]
    assert [s.stamp for s in statuses] == [0.5, 1.0, 1.5, 2.0]
    assert statuses[-1].modules[0].name == "probe"
    assert statuses[-1].modules[0].state == "active"
    daemon.request_shutdown("done")
    await task


async def test_faulted_module_shows_in_status_with_a_safe_stop(config: NavdConfig) -> None:
    journal: list[object] = []
    daemon = Daemon(
        config, [Probe(journal, fail_on_velocity=True)], clock=SimClock(), handle_signals=False
    )
    task = await _started(daemon)
    for _ in range(2):
        daemon.bus.publish(
            VelocityCommand(stamp=0, received=0, linear_mps=0.2, angular_radps=0.0, source="test")
        )
    status = daemon.status()
    assert status.modules[0].faulted and status.modules[0].handler_failures == 2
    assert status.safe_stop_reasons == ("module 'probe' faulted: RuntimeError: cannot drive",)
    assert any(isinstance(m, VelocityCommand) and m.source == "supervisor" for m in journal)
    daemon.request_shutdown("done")
    await task


async def test_config_change_is_applied_whole_and_reaches_the_bus(config: NavdConfig) -> None:
    journal: list[object] = []
    daemon = Daemon(config, [Probe(journal)], clock=SimClock(), handle_signals=False)
    task = await _started(daemon)
    daemon.bus.publish(
        ConfigChange(
            stamp=0,
            received=0,
            request_id="r1",
            changes={"lifecycle.handler_budget_ms": 4.0, "safety.reaction_timeout_s": 0.3},
            privileged=True,
        )
    )
    (applied,) = [m for m in journal if isinstance(m, ConfigApplied)]
    assert applied.changed_keys == ("safety.reaction_timeout_s", "lifecycle.handler_budget_ms")
    assert daemon.config.safety.reaction_timeout_s == 0.3
    assert daemon.bus.handler_budget_s == pytest.approx(0.004)
    daemon.request_shutdown("done")
    await task


async def test_a_privileged_change_is_refused_unless_its_source_may(config: NavdConfig) -> None:
    journal: list[object] = []
    daemon = Daemon(config, [Probe(journal)], clock=SimClock(), handle_signals=False)
    task = await _started(daemon)
    before = daemon.config
    daemon.bus.publish(
        ConfigChange(
            stamp=0,
            received=0,
            request_id="r3",
            changes={
                "planning.goal_weight": 2.0,
                "safety.use_collisions": False,
                "robot.max_linear_speed_mps": 10.0,
                "slam.map_name": "other",
            },
        )
    )
    (rejected,) = [m for m in journal if isinstance(m, ConfigRejected)]
    for key in ("safety.use_collisions", "robot.max_linear_speed_mps", "slam.map_name"):
        assert f"{key}: a privileged key" in rejected.reason
    assert "planning.goal_weight" not in rejected.reason
    assert "tcp.allow_privileged_changes" in rejected.reason
    assert daemon.config is before  # whole or nothing: the harmless key did not go in alone
    daemon.request_shutdown("done")
    await task


async def test_invalid_config_change_is_rejected_whole(config: NavdConfig) -> None:
    journal: list[object] = []
    daemon = Daemon(config, [Probe(journal)], clock=SimClock(), handle_signals=False)
    task = await _started(daemon)
    before = daemon.config
    daemon.bus.publish(
        ConfigChange(
            stamp=0,
            received=0,
            request_id="r2",
            changes={"safety.reaction_timeout_s": 0.3, "robot.max_linear_speed_mps": -1.0},
            privileged=True,
        )
    )
    (rejected,) = [m for m in journal if isinstance(m, ConfigRejected)]
    assert "robot.max_linear_speed_mps = -1.0" in rejected.reason
    assert daemon.config is before
    daemon.request_shutdown("done")
    await task


async def test_reload_applies_a_valid_file_and_keeps_the_old_config_on_a_bad_one(
    config: NavdConfig, tmp_path: Path
) -> None:
    path = tmp_path / "navd.toml"
    path.write_text(dump_toml(config))
    daemon = Daemon(config, clock=SimClock(), config_path=path, handle_signals=False)
    path.write_text(
        dump_toml(config).replace("reaction_timeout_s = 0.5", "reaction_timeout_s = 0.25")
    )
    assert daemon.reload_config()
    assert daemon.config.safety.reaction_timeout_s == 0.25
    path.write_text("[safety]\nreaction_timeout_s = 'soon'\n")
    assert not daemon.reload_config()
    assert daemon.config.safety.reaction_timeout_s == 0.25
    port = config.tcp.port
    path.write_text(dump_toml(config).replace(f"port = {port}", f"port = {port + 1}"))
    assert not daemon.reload_config()  # a restart-only key: rejected whole
    assert daemon.config.tcp.port == port


async def test_loop_lag_is_measured(config: NavdConfig) -> None:
    fast = parse_config({"lifecycle": {"lag_sample_period_s": 0.005}})
    daemon = Daemon(fast, clock=SimClock(), handle_signals=False)
    task = await _started(daemon)
    await asyncio.sleep(0.02)
    time.sleep(0.08)  # block the loop: the next probe wakes at least ~75 ms late
    await asyncio.sleep(0.02)
    assert daemon.status().loop_lag_max_ms >= 50.0
    daemon.request_shutdown("done")
    await task


async def test_the_switch_interval_is_the_configs_while_the_daemon_runs() -> None:
    # A worker running Python hands the interpreter to the waiting event loop after at most
    # this long; the process's own interval comes back when the daemon stops.
    before = sys.getswitchinterval()
    daemon = Daemon(
        parse_config({"lifecycle": {"switch_interval_ms": 0.7}}),
        clock=SimClock(),
        handle_signals=False,
    )
    task = await _started(daemon)
    assert sys.getswitchinterval() == pytest.approx(0.0007)
    daemon.request_shutdown("done")
    await task
    assert sys.getswitchinterval() == before


async def test_the_event_loop_thread_runs_with_the_configs_slice_while_the_daemon_runs() -> None:
    before = thread_slice_s()
    if before is None:
        pytest.skip("this kernel gives no task a slice of its own (Linux 6.12 and later do)")
    daemon = Daemon(
        parse_config({"lifecycle": {"loop_slice_ms": 0.25}}),
        clock=SimClock(),
        handle_signals=False,
    )
    task = await _started(daemon)
    assert thread_slice_s() == pytest.approx(0.00025)  # this thread runs the daemon's loop
    daemon.request_shutdown("done")
    await task
    assert thread_slice_s() == pytest.approx(before)
