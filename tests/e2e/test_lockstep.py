"""Simulated time in lockstep: the same seed gives the same drive, and ``navd sim`` is a
program of its own beside ``navd run`` (real processes, sockets and pseudo-terminal)."""

from __future__ import annotations

import asyncio
import json
import math
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any, BinaryIO

import pytest
import tomli_w

from navd.sim import from_shapes, session, sim_session
from navd.wire import AsyncClient, GoalFrame, GoalStatusFrame, InitialPoseFrame
from tests.e2e.conftest import REPO, free_port

pytestmark = pytest.mark.e2e

NAVD = [sys.executable, "-m", "navd"]

# A hall with a pillar and a person crossing beyond it: a drive with something to decide.
HALL = {
    "walls": [[-1, -1.5, 7, -1.5], [7, -1.5, 7, 1.5], [7, 1.5, -1, 1.5], [-1, 1.5, -1, -1.5]],
    "boxes": [[2.5, 0.5, 0.4, 0.4]],
    "movers": [{"radius": 0.25, "speed": 0.3, "path": [[4.3, -1.1], [4.3, 0.1]]}],
    "start": [0.0, 0.0, 0.0],
    "goal": [5.5, 0.0, 0.0],
}


async def _send_goal(control: AsyncClient, world: Any) -> None:
    x, y, yaw = world.start
    control.send(InitialPoseFrame(x=x, y=y, yaw=yaw, std_xy=0.02))
    gx, gy, gyaw = world.goal
    await control.request(GoalFrame(x=gx, y=gy, yaw=gyaw, goal_id="g"))


async def _drive(work: Path, sim_seconds: float) -> tuple[list[Any], list[Any]]:
    """Wheel lines and truth of a lockstep drive of ``sim_seconds`` [s] from time 0."""
    world = from_shapes(HALL, "hall")
    async with session(world, work, lockstep=True, hold_clock=True) as s:
        await _send_goal(s.control, world)
        s.sim.release_clock()
        while s.sim.now() < sim_seconds:
            s.check()
            await asyncio.sleep(0.05)
        wheels = [w for w in s.sim.robot.wheels.log if w[0] <= sim_seconds]
        truth = [t for t in s.sim.truth if t[0] <= sim_seconds]
    return wheels, truth


async def test_the_same_seed_drives_the_same_way(tmp_path: Path) -> None:
    first = await _drive(tmp_path / "one", 12.0)
    second = await _drive(tmp_path / "two", 12.0)
    wheels, truth = first
    assert len(wheels) > 200 and any(left != 0 for _, left, _ in wheels)  # it drove
    assert truth[-1][1] > 1.0
    assert second == first  # every wheel line and every truth sample, bit for bit


def _config(work: Path) -> tuple[Path, int]:
    """A daemon config on simulated time; its path and TCP port."""
    port = free_port()
    raw = {
        "chassis": {"enabled": True, "port": str(work / "tty"), "feedback": "encoders"},
        "tcp": {"port": port, "read_coalesce_ms": 0.0},
        "lifecycle": {"clock": "simulated", "event_loop": "asyncio"},
        "slam": {"map_dir": str(work / "maps")},
        "logging": {"format": "json"},
    }
    path = work / "navd.toml"
    path.write_text(tomli_w.dumps(raw), encoding="utf-8")
    return path, port


def _start_navd(config: Path, log: BinaryIO) -> subprocess.Popen[bytes]:
    """``navd run`` on ``config`` in its own process, its output into ``log``."""
    return subprocess.Popen(
        [*NAVD, "run", "--config", str(config)], cwd=REPO, stdout=log, stderr=log
    )


async def test_navd_sim_drives_navd_run_as_two_programs(tmp_path: Path) -> None:
    world_path = tmp_path / "hall.toml"
    world_path.write_text(tomli_w.dumps(HALL), encoding="utf-8")
    config, port = _config(tmp_path)
    truth = tmp_path / "truth.csv"
    log = (tmp_path / "navd.log").open("wb")
    daemon = _start_navd(config, log)
    sim = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "navd",
            "sim",
            "--config",
            str(config),
            "--world",
            str(world_path),
            "--truth",
            str(truth),
        ],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        control = await AsyncClient.connect("127.0.0.1", port, ready_timeout_s=30.0)
        await _send_goal(control, from_shapes(HALL, "hall"))
        state = ""
        for _ in range(600):  # simulated time runs while we wait: at most a minute
            try:
                frame = await control.receive(0.1)
            except TimeoutError:
                continue
            if isinstance(frame, GoalStatusFrame) and frame.state in ("reached", "failed"):
                state = frame.state
                break
        await control.close()
        assert state == "reached"
    finally:
        sim.terminate()
        out, err = sim.communicate(timeout=30)
        daemon.terminate()
        daemon.wait(timeout=30)
        log.close()
    assert sim.returncode == 0, err
    summary = json.loads(out)
    assert summary["clock"] == "lockstep" and summary["collisions"] == 0
    rows = truth.read_text().splitlines()
    assert rows[0] == "t_s,x_m,y_m,yaw_rad"
    t, x, y, _ = (float(v) for v in rows[-1].split(","))
    assert t > 5.0
    assert math.hypot(x - 5.5, y) < 0.3


def test_navd_sim_on_simulated_time_stops_on_the_step_at_its_limit(tmp_path: Path) -> None:
    # --limit on simulated time ends on the step at the limit itself, so the summary is the
    # run's, not the machine's (a watch of the time in real time used to stop it a varying
    # number of steps later).
    world_path = tmp_path / "hall.toml"
    world_path.write_text(tomli_w.dumps(HALL), encoding="utf-8")
    config, _ = _config(tmp_path)
    log = (tmp_path / "navd.log").open("wb")
    daemon = _start_navd(config, log)
    try:
        sim = subprocess.run(
            [*NAVD, "sim", "--config", str(config), "--world", str(world_path), "--limit", "3"],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
    finally:
        daemon.terminate()
        daemon.wait(timeout=30)
        log.close()
    assert sim.returncode == 0, sim.stderr
    summary = json.loads(sim.stdout)
    assert summary["clock"] == "lockstep"
    assert summary["sim_time_s"] == 3.0
    assert summary["chassis_lines"] > 0  # navd drove the wheels (with zeros: no goal)


async def test_a_session_whose_free_port_is_taken_first_starts_on_another(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Another program may take the free port before the daemon binds it (many sockets come
    and go in a suite): the daemon says so and exits, and the session starts again on
    another port instead of failing."""
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen()
    ports = iter([taken.getsockname()[1]])
    monkeypatch.setattr(sim_session, "free_port", lambda: next(ports, None) or free_port())
    try:
        async with session(from_shapes(HALL, "hall"), tmp_path, lockstep=True) as s:
            assert s.port != taken.getsockname()[1]
            while s.sim.now() < 1.0:  # time runs: the simulator found this daemon too
                s.check()
                await asyncio.sleep(0.05)
    finally:
        taken.close()
