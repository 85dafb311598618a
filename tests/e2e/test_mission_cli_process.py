"""``navd mission`` on the real daemon: run (and --wait, with its exit codes), status,
pause, resume, continue and cancel, each with its errors (daemon not running, a file that
is not a mission, nothing to pause)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from navd.sim import free_port
from tests.e2e.conftest import REPO, run_navd

pytestmark = pytest.mark.e2e

WAITS = """\
name = "two waits"
rounds = 2

[[steps]]
kind = "wait"
seconds = 0.3
"""

HELD = """\
name = "held"

[[steps]]
kind = "pause"
message = "press the button"

[[steps]]
kind = "wait"
seconds = 60
"""


def _follow(file: Path, port: int) -> subprocess.Popen[str]:
    """``navd mission run FILE --wait`` in the background."""
    return subprocess.Popen(
        [sys.executable, "-m", "navd", "mission", "run", str(file), "--wait", "--port", str(port)],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _said(port: int, wanted: str, timeout_s: float = 10.0) -> str:
    """``navd mission status`` until it says ``wanted``."""
    deadline = time.monotonic() + timeout_s
    said = ""
    while time.monotonic() < deadline:
        said = run_navd("mission", "status", "--port", str(port)).stdout
        if wanted in said:
            return said
        time.sleep(0.2)
    raise AssertionError(f"navd mission status never said {wanted!r}; last: {said!r}")


def test_a_mission_of_waits_runs_to_its_end_with_a_line_per_step(
    daemon_on_port: Any, tmp_path: Path
) -> None:
    _, port = daemon_on_port()
    at = ("--port", str(port))
    assert run_navd("mission", "status", *at).stdout.strip() == "no mission"
    file = tmp_path / "waits.toml"
    file.write_text(WAITS)
    done = run_navd("mission", "run", str(file), "--wait", "--id", "w1", *at)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == "mission w1 sent: 1 step, 2 rounds"  # the ack
    assert sum("[step_done]" in line for line in lines) == 2
    assert "round 2/2" in lines[-1] and "completed" in lines[-1]
    assert "w1 completed" in run_navd("mission", "status", *at).stdout


def test_pause_continue_resume_and_cancel_from_other_commands(
    daemon_on_port: Any, tmp_path: Path
) -> None:
    _, port = daemon_on_port()
    at = ("--port", str(port))
    refused = run_navd("mission", "pause", *at)
    assert refused.returncode == 1 and "no mission has been run" in refused.stdout
    file = tmp_path / "held.toml"
    file.write_text(HELD)
    follower = _follow(file, port)
    try:
        said = _said(port, "waiting")
        assert "press the button" in said and "navd mission continue" in said
        assert run_navd("mission", "continue", *at).returncode == 0
        _said(port, "step 2/2 wait")
        assert run_navd("mission", "pause", *at).returncode == 0
        _said(port, "paused")
        again = run_navd("mission", "pause", *at)
        assert again.returncode == 1 and "not running" in again.stdout
        assert run_navd("mission", "resume", *at).returncode == 0
        _said(port, "running")
        assert run_navd("mission", "cancel", *at).returncode == 0
        out, err = follower.communicate(timeout=15)
    finally:
        if follower.poll() is None:
            follower.kill()
    assert follower.returncode == 3, err  # followed to its end: cancelled
    assert "canceled" in out.splitlines()[-1]
    late = run_navd("mission", "resume", *at)
    assert late.returncode == 1 and "has ended" in late.stdout


def test_a_file_that_is_not_a_mission_is_refused_by_name(tmp_path: Path) -> None:
    port = str(free_port())  # nothing listens: the file is checked before connecting
    cases = {
        "typo.toml": ('[[steps]]\nkind = "goto"\nx = 1.0\nyy = 2.0\n', "steps.0.yy"),
        "half.toml": ('[[steps]]\nkind = "goto"\nx = 1.0\n', "needs y"),
        "kind.toml": ('[[steps]]\nkind = "fly"\n', "steps.0.kind"),
        "none.toml": ("name = 'empty'\nsteps = []\n", "steps"),
        "broken.json": ('{"steps": [', "not valid JSON"),
        "list.json": ("[1, 2]", "a mission is a table"),
    }
    for name, (text, named) in cases.items():
        (tmp_path / name).write_text(text)
        result = run_navd("mission", "run", str(tmp_path / name), "--port", port)
        assert result.returncode == 2, (name, result.stderr)
        assert named in result.stderr, (name, result.stderr)
    missing = run_navd("mission", "run", str(tmp_path / "nope.toml"), "--port", port)
    assert missing.returncode == 2 and "cannot be read" in missing.stderr
    # Named as the mission file it is, not as a config.
    assert f"mission file {tmp_path / 'nope.toml'}: 1 problem" in missing.stderr
    assert "config" not in missing.stderr


def test_without_a_daemon_each_command_says_so(tmp_path: Path) -> None:
    port = str(free_port())
    file = tmp_path / "waits.toml"
    file.write_text(WAITS)
    for args in (("run", str(file)), ("status",), ("pause",), ("continue",)):
        result = run_navd("mission", *args, "--port", port)
        assert result.returncode == 1, (args, result.stderr)
        assert "navd mission" in result.stderr and port in result.stderr, (args, result.stderr)


def test_waiting_on_a_mission_longer_than_the_idle_timeout_sees_it_to_its_end(
    daemon_on_port: Any, tmp_path: Path
) -> None:
    _, port = daemon_on_port("control_idle_timeout_s = 1.0\n")
    file = tmp_path / "long.toml"
    file.write_text('[[steps]]\nkind = "wait"\nseconds = 4.0\n')  # four idle timeouts long
    done = run_navd("mission", "run", str(file), "--wait", "--id", "long", "--port", str(port))
    assert done.returncode == 0, done.stderr
    assert "long completed" in done.stdout.splitlines()[-1]
