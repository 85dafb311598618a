"""``navd demo`` end to end: the real daemon process drives the simulated robot (chassis on a
real pseudo-terminal, sensors over real TCP) to a goal, and the results are written."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from PIL import Image

from navd.cli import main
from navd.sim import free_port, from_shapes, run_demo
from tests.e2e.conftest import REPO, run_navd
from tests.viz.foxglove_client import FoxgloveClient

# A 6 m x 3 m room with a box in the middle of the straight line to the goal.
ROOM = {
    "walls": [[-1, -1.5, 5, -1.5], [5, -1.5, 5, 1.5], [5, 1.5, -1, 1.5], [-1, 1.5, -1, -1.5]],
    "boxes": [[1.6, -0.4, 0.6, 0.8]],
    "start": [0.0, 0.0, 0.0],
    "goal": [3.8, 0.0, 0.0],
}


def test_the_demo_drives_around_a_box_to_the_goal_and_writes_its_results(tmp_path: Path) -> None:
    world = from_shapes(ROOM, "room")
    summary = run_demo(world, tmp_path, limit_s=60.0, progress=False)
    assert summary["reached"], summary
    assert summary["collisions"] == 0
    assert summary["min_clearance_m"] >= 0.1  # the guard's stop distance, less the sim's grid
    assert summary["final_distance_to_goal_m"] <= 0.2
    assert summary["final_pose_error_m"] <= 0.15
    assert summary["driven_length_m"] > 3.8  # not through the box
    assert summary["chassis_lines"] > 100  # it drove through the wheel commands
    assert json.loads((tmp_path / "summary.json").read_text()) == summary
    picture = np.asarray(Image.open(tmp_path / "demo.png").convert("RGB"))
    assert picture.shape == (int(np.ceil(5.0 / 0.025)), int(np.ceil(8.0 / 0.025)), 3)
    colours = {tuple(c) for c in picture.reshape(-1, 3)}
    for colour in [(220, 30, 30), (20, 160, 60), (40, 90, 230), (20, 20, 20)]:
        assert colour in colours  # truth, estimate, route and the map navd built
    assert (tmp_path / "demo.log").stat().st_size > 0


def test_the_demo_on_simulated_time_is_the_same_drive_every_time(tmp_path: Path) -> None:
    # The README's promise: the simulator owns the clock, so a second run gives the same
    # summary, wheel lines included (the simulation runs on while the map is saved, for as
    # long as that takes: those lines were once counted and the figure varied), and the
    # same picture.
    world = from_shapes(ROOM, "room")
    first = run_demo(world, tmp_path / "first", limit_s=60.0, progress=False)
    second = run_demo(world, tmp_path / "second", limit_s=60.0, progress=False)
    assert first["reached"], first
    assert second == first
    pictures = [(tmp_path / run / "demo.png").read_bytes() for run in ("first", "second")]
    assert pictures[0] == pictures[1]


def test_demo_refuses_a_bad_world_by_name(tmp_path: Path) -> None:
    world = tmp_path / "bad.toml"
    world.write_text("walls = [[0, 0, 1]]\n")
    result = run_navd("demo", "--world", str(world), "--out", str(tmp_path))
    assert result.returncode == 2
    assert "walls[0] must be 4 finite numbers" in result.stderr


def _children(pid: int) -> list[int]:
    listed = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    return [int(child) for child in listed.split()]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_sigterm_ends_the_demo_with_its_results_and_leaves_nothing_running(
    tmp_path: Path,
) -> None:
    # A timeout, systemd or kill sends SIGTERM to the demo alone: it used to die at once and
    # leave its daemon running (with three ports open) and its working folder behind.
    world = tmp_path / "room.toml"
    world.write_text(tomli_w.dumps(ROOM))
    out = tmp_path / "out"
    demo = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "navd",
            "demo",
            "--world",
            str(world),
            "--out",
            str(out),
            "--real-time",
        ],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 120.0  # a cold kernel cache compiles first
        log = out / "demo.log"
        while not (log.exists() and '"ready"' in log.read_text()):
            assert demo.poll() is None and time.monotonic() < deadline, "the demo never started"
            time.sleep(0.2)
        time.sleep(2.0)  # driving
        (daemon,) = _children(demo.pid)
        config = Path(Path(f"/proc/{daemon}/cmdline").read_bytes().split(b"\0")[-2].decode())
        assert config.name == "navd.toml" and config.parent.is_dir()
        demo.send_signal(signal.SIGTERM)
        out_text, err = demo.communicate(timeout=60)
    finally:
        if demo.poll() is None:
            demo.kill()
            demo.communicate()
    assert demo.returncode == 1, err  # the goal was not reached
    summary = json.loads((out / "summary.json").read_text())
    assert json.loads(out_text) == summary
    assert (summary["state"], summary["reason"]) == ("canceled", "the demo was ended")
    assert (out / "demo.png").stat().st_size > 0
    assert not _alive(daemon)
    assert not config.parent.exists()


def test_a_viewed_demo_serves_the_page_and_the_live_view_on_the_ports_asked_for(
    tmp_path: Path,
) -> None:
    # The documented SSH tunnel names both ports: they used to be free ones picked at each
    # run, and only the page's was printed.
    world = tmp_path / "room.toml"
    world.write_text(tomli_w.dumps(ROOM))
    out = tmp_path / "out"
    view_port = free_port()
    page_port = next(p for p in iter(free_port, None) if p != view_port)
    command = [sys.executable, "-m", "navd", "demo", "--world", str(world), "--out", str(out)]
    command += ["--view", "--port", str(view_port), "--page-port", str(page_port)]
    # BROWSER=true: the page "opens" in a command that does nothing
    env = dict(os.environ, BROWSER="true")
    demo = subprocess.Popen(command, cwd=REPO, env=env, stderr=subprocess.PIPE, text=True)
    said: list[str] = []
    assert demo.stderr is not None
    reader = threading.Thread(target=lambda: said.extend(demo.stderr or ()), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 120.0  # a cold kernel cache compiles first
        while not any("the live view is at" in line for line in said):
            assert demo.poll() is None and time.monotonic() < deadline, said
            time.sleep(0.1)
        assert f"the operator page is at http://127.0.0.1:{page_port}/\n" in "".join(said)
        assert f"the live view is at ws://127.0.0.1:{view_port} " in "".join(said)
        with urllib.request.urlopen(f"http://127.0.0.1:{page_port}/", timeout=10) as page:
            assert page.status == 200 and b"<html" in page.read().lower()

        async def watch() -> None:
            viewer = await FoxgloveClient.open(view_port)
            try:
                await viewer.wait_for_topics({"/map", "/scan", "/pose"}, timeout_s=30.0)
            finally:
                await viewer.close()

        asyncio.run(watch())
        demo.send_signal(signal.SIGTERM)
        demo.wait(timeout=60)
    finally:
        if demo.poll() is None:
            demo.kill()
            demo.wait()
    reader.join(5.0)
    assert (out / "summary.json").exists()


def test_demo_ports_are_refused_by_name(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = ["--out", str(tmp_path)]
    assert main(["demo", "--port", "9000", *out]) == 2
    assert "--port and --page-port need --view" in capsys.readouterr().err
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert main(["demo", "--view", "--page-port", str(port), *out]) == 2
        assert f"--page-port {port} cannot be used on 127.0.0.1" in capsys.readouterr().err
    assert main(["demo", "--view", "--port", "9000", "--page-port", "9000", *out]) == 2
    assert "both 9000: give each its own" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["demo", "--view", "--port", "70000", *out])
    assert "'70000' is not a port (1 to 65535)" in capsys.readouterr().err
