"""The map kept through a crash, on the real daemon and the simulated robot: killed with
SIGKILL while mapping, the daemon started again goes on from the map it autosaved at most
``slam.autosave_period_s`` before, finds the robot on it, and a clean stop then removes the
autosave."""

from __future__ import annotations

import asyncio
import json
import signal
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from navd.sim import office, session
from navd.slam import load_map_state
from navd.wire import GoalFrame, InitialPoseFrame

pytestmark = pytest.mark.e2e

PERIOD_S = 1.0


async def _until(check: Any, limit_s: float, what: str) -> None:
    deadline = time.monotonic() + limit_s
    while not check():
        if time.monotonic() > deadline:
            raise AssertionError(f"{what} not within {limit_s} s")
        await asyncio.sleep(0.1)


def _events(log: Path) -> list[dict[str, Any]]:
    lines = log.read_text(encoding="utf-8", errors="replace").splitlines() if log.exists() else []
    return [json.loads(line) for line in lines if line.startswith("{")]


async def test_a_daemon_killed_while_mapping_goes_on_from_its_autosave(tmp_path: Path) -> None:
    overrides = {"slam": {"autosave_period_s": PERIOD_S}}
    async with session(office(), tmp_path, overrides=overrides) as s:
        autosave = s.maps / "autosave.yaml"
        s.control.send(InitialPoseFrame(x=s.sim.body.x_m, y=s.sim.body.y_m, yaw=0.0))
        s.control.send(GoalFrame(x=s.sim.body.x_m + 2.0, y=s.sim.body.y_m))
        await _until(autosave.exists, 60.0, "an autosave")
        await asyncio.sleep(3 * PERIOD_S)  # mapping on, saved again and again
        s.daemon.send_signal(signal.SIGKILL)
        killed_at = time.monotonic()
        await s.daemon.wait()
        saved = load_map_state(autosave)  # what the crash left: a whole, readable map
        assert not saved.grid.empty and saved.graph is not None
        assert time.monotonic() - killed_at < 30.0
        # started again as systemd would: the simulated sensors and chassis find it again
        log = tmp_path / "restarted.log"
        with log.open("wb") as out:
            again = await asyncio.create_subprocess_exec(
                sys.executable, "-m", "navd", "run", "--config", str(tmp_path / "navd.toml"),
                stdout=out, stderr=out,
            )  # fmt: skip
        try:
            names = lambda: {e.get("event") for e in _events(log)}  # noqa: E731
            await _until(lambda: "map_recovered" in names(), 60.0, "the map recovered")
            # said once the file is read, a moment after (longer on a busy machine)
            await _until(lambda: "map_loaded" in names(), 60.0, "the map loaded")
            loaded = next(e for e in _events(log) if e.get("event") == "map_loaded")
            assert loaded["path"] == str(autosave) and loaded["keyframes"] >= 1
            await _until(lambda: "relocalized" in names(), 60.0, "the robot found on it")
        finally:
            again.send_signal(signal.SIGTERM)
            await asyncio.wait_for(again.wait(), 30.0)
        assert again.returncode == 0
        assert not autosave.exists(), "a clean stop removes the autosave"
