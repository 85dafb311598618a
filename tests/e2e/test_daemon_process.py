"""The real daemon process: start-up, idling without sensors, clean exit on signals."""

from __future__ import annotations

import json
import signal
import time
from typing import Any

import pytest

from tests.e2e.conftest import READY_S, STOP_S, default_config, free_port, run_navd

pytestmark = pytest.mark.e2e


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_daemon_gets_ready_idles_and_exits_0_on_signal(
    spawn_daemon: Any, sig: int, tmp_path: Any
) -> None:
    daemon = spawn_daemon("run", "--config", str(default_config(tmp_path)))
    ready = daemon.wait_for("ready", timeout_s=READY_S)
    assert ready["component"] == "lifecycle" and ready["level"] == "info"
    time.sleep(1.0)  # no sensors attached: it keeps running
    assert daemon.proc.poll() is None
    daemon.proc.send_signal(sig)
    assert daemon.proc.wait(timeout=STOP_S) == 0
    zero = daemon.wait_for("zero_velocity", timeout_s=1.0)
    assert zero["reason"] == f"signal {signal.Signals(sig).name}"
    daemon.wait_for("stopped", timeout_s=1.0)


def test_a_daemon_stopped_while_its_kernels_compile_exits_0_at_once(
    spawn_daemon: Any, tmp_path: Any
) -> None:
    # An empty numba cache: the kernels take seconds to compile, in threads beside the loop.
    cold = {"NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    daemon = spawn_daemon("run", "--config", str(default_config(tmp_path)), env=cold)
    daemon.wait_for("ready", timeout_s=READY_S)
    daemon.proc.send_signal(signal.SIGTERM)
    assert daemon.proc.wait(timeout=STOP_S) == 0  # not an abort from under the compiler
    daemon.wait_for("stopped", timeout_s=1.0)
    assert daemon.wait_for("exit_without_waiting", timeout_s=1.0)["threads"]


def test_daemon_logs_the_effective_config_at_start(spawn_daemon: Any, tmp_path: Any) -> None:
    path = tmp_path / "port-only.toml"
    path.write_text(f"[tcp]\nport = {free_port()}\n")  # every other key at its default
    daemon = spawn_daemon("run", "--config", str(path))
    starting = daemon.wait_for("starting", timeout_s=READY_S)
    assert starting["config"]["safety"]["reaction_timeout_s"] == 0.5
    daemon.wait_for("ready", timeout_s=READY_S)
    daemon.proc.send_signal(signal.SIGTERM)
    assert daemon.proc.wait(timeout=2.0) == 0


def _config_status(port: int) -> dict[str, Any]:
    result = run_navd("status", "--once", "--json", "--port", str(port))
    assert result.returncode == 0, result.stderr
    config: dict[str, Any] = json.loads(result.stdout)["diagnostics"]["config"]
    return config


def test_sighup_reloads_and_rejects_on_the_real_process(spawn_daemon: Any, tmp_path: Any) -> None:
    port = free_port()
    path = tmp_path / "navd.toml"
    path.write_text(f"[tcp]\nport = {port}\n[safety]\nreaction_timeout_s = 0.5\n")
    daemon = spawn_daemon("run", "--config", str(path))
    daemon.wait_for("ready", timeout_s=READY_S)
    assert _config_status(port)["revision"] == 0
    path.write_text(f"[tcp]\nport = {port}\n[safety]\nreaction_timeout_s = 0.3\n")
    daemon.proc.send_signal(signal.SIGHUP)
    applied = daemon.wait_for("config_applied", timeout_s=2.0)
    assert applied["changed"] == ["safety.reaction_timeout_s"]
    status = _config_status(port)
    assert status["revision"] == 1
    assert status["last_applied"]["changed"] == ["safety.reaction_timeout_s"]
    path.write_text(f"[tcp]\nport = {port}\n[safety]\nreaction_timeout_s = 'later'\n")
    daemon.proc.send_signal(signal.SIGHUP)
    rejected = daemon.wait_for("config_rejected", timeout_s=2.0)
    assert any("safety.reaction_timeout_s" in p for p in rejected["problems"])
    status = _config_status(port)
    assert status["revision"] == 1  # the running config was not touched
    assert "safety.reaction_timeout_s = 'later'" in status["last_rejected"]["reason"]
    assert daemon.proc.poll() is None
    daemon.proc.send_signal(signal.SIGTERM)
    assert daemon.proc.wait(timeout=2.0) == 0


def test_config_check_command_names_the_bad_key(tmp_path: Any) -> None:
    path = tmp_path / "navd.toml"
    path.write_text("[chassis]\nbaudrate = 115201\n")
    result = run_navd("config", "check", str(path))
    assert result.returncode == 2
    assert "chassis.baudrate 115201 is not a standard rate" in result.stderr


def test_real_daemon_speaks_sd_notify(spawn_daemon: Any, tmp_path: Any, monkeypatch: Any) -> None:
    from tests.lifecycle.test_sdnotify import NotifyListener

    listener = NotifyListener(tmp_path / "notify")
    monkeypatch.setenv("NOTIFY_SOCKET", str(listener.path))
    monkeypatch.setenv("WATCHDOG_USEC", "200000")
    try:
        daemon = spawn_daemon("run", "--config", str(default_config(tmp_path)))
        daemon.wait_for("ready", timeout_s=READY_S)
        time.sleep(1.0)
        daemon.proc.send_signal(signal.SIGTERM)
        assert daemon.proc.wait(timeout=2.0) == 0
        listener.wait_for("STOPPING=1")
    finally:
        listener.close()
    lines = listener.lines()
    assert lines[0] == "READY=1\nSTATUS=running"
    assert lines.count("WATCHDOG=1") >= 5  # every 0.1 s for a second, on a busy machine too
    assert any(line.startswith("STATUS=running") and "loop lag p99" in line for line in lines)
    stopping = [i for i, line in enumerate(lines) if line.startswith("STOPPING=1")]
    assert len(stopping) == 1 and stopping[0] > lines.index("READY=1\nSTATUS=running")


def test_a_log_level_changed_at_runtime_reaches_every_logger(daemon_on_port: Any) -> None:
    from navd.wire import Client, ConfigAppliedFrame, ConfigFrame, GoalFrame

    daemon, port = daemon_on_port()
    with Client("127.0.0.1", port, device_id="ui") as ui:
        # A goal and no pose: every control tick holds the robot and says so at debug level.
        ui.request(GoalFrame(x=1.0, y=0.0))
        time.sleep(0.5)
        assert not [line for line in daemon.drain() if line.get("event") == "planner_stop"]
        ui.request(ConfigFrame(changes={"logging.level": "debug"}))
        ui.receive_type(ConfigAppliedFrame)
        held = daemon.wait_for("planner_stop", timeout_s=3.0)
    assert held["level"] == "debug" and held["component"] == "planner"
