"""The operator's command line on the real daemon: config get and set, pose set, map save,
and goal --wait with its exit codes, each with its errors (daemon not running, no map yet, a
folder that cannot be written, a key that does not exist or may not change)."""

from __future__ import annotations

import asyncio
import json
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from navd.sim import free_port, from_shapes, session
from navd.wire import CancelFrame, InitialPoseFrame
from tests.e2e.conftest import run_navd
from tests.e2e.test_safety_process import Lidar
from tests.e2e.test_scenarios import HALL

pytestmark = pytest.mark.e2e


def test_config_get_and_set_on_the_running_daemon(daemon_on_port: Any) -> None:
    _, port = daemon_on_port()
    at = ("--port", str(port))
    got = run_navd("config", "get", "planning.goal_weight", *at)
    assert got.returncode == 0 and got.stdout.strip() == "1.0"
    put = run_navd("config", "set", "planning.goal_weight", "2.5", *at)
    assert put.returncode == 0, put.stderr
    assert run_navd("config", "get", "planning.goal_weight", *at).stdout.strip() == "2.5"
    section = json.loads(run_navd("config", "get", "planning", *at).stdout)
    assert section["goal_weight"] == 2.5
    refused = run_navd("config", "set", "safety.use_collisions", "false", *at)
    assert refused.returncode == 1 and "privileged" in refused.stderr
    wrong = run_navd("config", "set", "planning.goal_weight", "heavy", *at)
    assert wrong.returncode == 1 and "planning.goal_weight" in wrong.stderr
    unknown = run_navd("config", "get", "planning.no_such_key", *at)
    assert unknown.returncode == 1 and "no key 'no_such_key'" in unknown.stderr


def test_a_secret_is_never_read_back(daemon_on_port: Any) -> None:
    token = "a-token-of-twenty-chars"
    _, port = daemon_on_port(f'token = "{token}"\n')  # in the fixture's [tcp]
    got = run_navd("config", "get", "tcp.token", "--port", str(port), "--token", token)
    assert got.returncode == 0 and token not in got.stdout and "redacted" in got.stdout


def test_pose_set_and_map_save_report_what_happened(daemon_on_port: Any, tmp_path: Path) -> None:
    maps = tmp_path / "maps"
    _, port = daemon_on_port(f'[slam]\nmap_dir = "{maps}"\n')
    at = ("--port", str(port))
    empty = run_navd("map", "save", *at)
    assert empty.returncode == 1 and "the map is empty" in empty.stderr
    assert run_navd("pose", "set", "0", "0", "0", "--std-xy", "0.05", *at).returncode == 0
    lidar = Lidar(port)
    lidar.start()
    try:
        deadline = time.monotonic() + 20.0
        saved = run_navd("map", "save", "lab", *at)
        while saved.returncode != 0 and time.monotonic() < deadline:  # the first scans map
            time.sleep(0.5)
            saved = run_navd("map", "save", "lab", *at)
        found = run_navd("pose", "find", *at)  # the whole map searched at the next scan
    finally:
        lidar.halt.set()
        lidar.join()
    assert saved.returncode == 0, saved.stderr
    written = [Path(line.removeprefix("wrote ")) for line in saved.stdout.splitlines()]
    assert [p.suffix for p in written] == [".yaml", ".pgm", ".npz"]
    assert all(p.is_file() and p.parent == maps for p in written)
    assert found.returncode == 0, found.stderr
    x, y = (float(v) for v in found.stdout.split("(")[1].split(")")[0].split(","))
    assert abs(x) < 0.3 and abs(y) < 0.3  # the middle of the square room it maps
    bad = run_navd("pose", "set", "1", "2", "100", *at)
    assert bad.returncode == 2 and "yaw" in bad.stderr
    loaded = run_navd("map", "load", "lab", *at)
    assert loaded.returncode == 0 and str(maps / "lab.yaml") in loaded.stdout, loaded.stderr
    missing = run_navd("map", "load", "nosuch", *at)
    assert missing.returncode == 1 and "nosuch.yaml" in missing.stderr
    untrusted = run_navd("map", "load", str(tmp_path / "elsewhere" / "lab.yaml"), *at)
    assert untrusted.returncode == 1 and "tcp.allow_privileged_changes" in untrusted.stderr


def test_map_save_and_load_by_path(daemon_on_port: Any, tmp_path: Path) -> None:
    # a folder of the robot's disk is as privileged as slam.map_dir
    trusted = "allow_privileged_changes = true\n"  # in the fixture's [tcp]
    _, port = daemon_on_port(f'{trusted}[slam]\nmap_dir = "{tmp_path / "maps"}"\n')
    at = ("--port", str(port))
    lidar = Lidar(port)
    lidar.start()
    try:
        deadline = time.monotonic() + 20.0
        target = tmp_path / "elsewhere" / "deep" / "hall.yaml"
        saved = run_navd("map", "save", str(target), *at)
        while saved.returncode != 0 and time.monotonic() < deadline:  # the first scans map
            time.sleep(0.5)
            saved = run_navd("map", "save", str(target), *at)
        # a file where the folder should be: nothing can be written there, and it says so
        blocker = tmp_path / "blocker"
        blocker.write_text("not a folder")
        refused = run_navd("map", "save", str(blocker / "hall.yaml"), *at)
    finally:
        lidar.halt.set()
        lidar.join()
    assert saved.returncode == 0, saved.stderr
    written = [Path(line.removeprefix("wrote ")) for line in saved.stdout.splitlines()]
    assert written[0] == target and all(p.is_file() for p in written)
    assert not (tmp_path / "maps" / "hall.yaml").exists()
    assert refused.returncode == 1 and "cannot write" in refused.stderr
    assert str(blocker) in refused.stderr
    loaded = run_navd("map", "load", str(target), *at)
    assert loaded.returncode == 0 and str(target) in loaded.stdout, loaded.stderr
    nowhere = run_navd("map", "load", str(tmp_path / "nowhere" / "lab.yaml"), *at)
    assert nowhere.returncode == 1 and str(tmp_path / "nowhere") in nowhere.stderr


def test_map_save_into_a_folder_it_cannot_write_says_why(
    daemon_on_port: Any, tmp_path: Path
) -> None:
    blocker = tmp_path / "maps"
    blocker.write_text("a file where the map folder should be")
    _, port = daemon_on_port(f'[slam]\nmap_dir = "{blocker}"\n')
    lidar = Lidar(port)
    lidar.start()
    try:
        time.sleep(2.0)  # a map to save
        saved = run_navd("map", "save", "--port", str(port))
    finally:
        lidar.halt.set()
        lidar.join()
    assert saved.returncode == 1 and "cannot write" in saved.stderr


def test_without_a_daemon_each_command_says_it_cannot_reach_it() -> None:
    port = str(free_port())
    for command in (
        ("config", "get", "planning.goal_weight"),
        ("config", "set", "planning.goal_weight", "2"),
        ("pose", "set", "0", "0", "0"),
        ("pose", "find"),
        ("map", "save"),
        ("map", "load", "lab"),
        ("goal", "1", "0", "--wait"),
    ):
        done = run_navd(*command, "--port", port)
        assert done.returncode == 1 and "cannot reach navd" in done.stderr, command


async def _navd(*args: str) -> asyncio.subprocess.Process:
    return await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "navd",
        *args,
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )


async def test_goal_wait_exits_by_how_the_goal_ended(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    async with session(world, tmp_path) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        at = ("--port", str(s.port))
        reached = await _navd("goal", "2.0", "0.0", "--wait", "--id", "near", *at)
        out, err = await asyncio.wait_for(reached.communicate(), 120.0)
        assert reached.returncode == 0, err.decode()
        assert out.decode().splitlines() == ["goal near sent: (2.00, 0.00) m", "near: reached"]
        assert "near: active" in err.decode()  # the progress line
        far = await _navd("goal", "5000", "0", "--wait", "--json", *at)
        out, err = await asyncio.wait_for(far.communicate(), 60.0)
        assert far.returncode == 1 and "max_goal_distance_m" in err.decode()
        assert json.loads(out.decode().splitlines()[-1])["state"] == "failed"
        canceled = await _navd("goal", "5.5", "0.0", "--wait", "--id", "away", *at)
        await asyncio.sleep(3.0)
        await s.control.request(CancelFrame(goal_id="away"))
        _, err = await asyncio.wait_for(canceled.communicate(), 60.0)
        assert canceled.returncode == 3 and "canceled" in err.decode()
