"""navd driven by a VDA 5050 master it was not written with: vda-5050-lib's MasterController
(npm, speaking 2.0, validating every message against its own 2.0 schemas and dropping what
fails) gives the vehicle on a real mosquitto an order through the simulated office: driven
to its end, each node heard traversed; and an order whose last node is released by an
update, then paused, resumed and cancelled, each heard finished."""

from __future__ import annotations

import asyncio
import json
import math
import shutil
from pathlib import Path
from typing import Any

import pytest

from navd.sim import office, session
from navd.wire import InitialPoseFrame
from tests.e2e.test_fleet_mqtt import ROUTE, SERIAL, _vehicle, fleet_side
from tests.fleet.broker import Broker

pytestmark = pytest.mark.e2e

JS = Path(__file__).resolve().parents[1] / "js"
NODE = shutil.which("node")


def _master_or_skip() -> str:
    if NODE is None:
        pytest.skip("node is not installed (`make test` installs nodejs and npm as root with apt)")
    if not (JS / "node_modules" / "vda-5050-lib").is_dir():
        pytest.skip(
            "vda-5050-lib is not installed in tests/js (`make test` runs npm ci there where npm "
            "and its registry can be reached)"
        )
    return NODE


async def _said(master: asyncio.subprocess.Process, s: Any, limit_s: float) -> list[dict[str, Any]]:
    """What the master says, line by line, until it ends (it does once done with its order)."""
    assert master.stdout is not None
    said: list[dict[str, Any]] = []
    deadline = s.sim.now() + limit_s
    while s.sim.now() < deadline:
        s.check()
        try:
            line = await asyncio.wait_for(master.stdout.readline(), 0.5)
        except TimeoutError:
            continue
        if not line:
            break
        said.append(json.loads(line))
    return said


async def _run_master(
    tmp_path: Path, scenario: str
) -> tuple[list[dict[str, Any]], tuple[float, float], int]:
    """What the master said in ``scenario``, where the robot ended and its collisions."""
    node = _master_or_skip()
    broker = Broker(tmp_path)
    broker.start()
    try:
        async with session(
            office(), tmp_path, overrides=_vehicle(broker), lockstep=True, hold_clock=True
        ) as s, fleet_side(broker) as watcher:  # fmt: skip
            s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
            s.sim.release_clock()
            await watcher.until("state", lambda m: "agvPosition" in m, s, 30.0)  # localized
            route = json.dumps([[name, x, y] for name, x, y in ROUTE])
            errors = (tmp_path / "master.err").open("wb")  # what the master said of itself
            master = await asyncio.create_subprocess_exec(
                node, str(JS / "vda5050_master.js"), broker.url, "navd", SERIAL, "map", route,
                scenario,
                cwd=JS, stdout=asyncio.subprocess.PIPE, stderr=errors,
            )  # fmt: skip
            try:
                said = await _said(master, s, 240.0)
            finally:
                if master.returncode is None:
                    master.kill()
                await master.wait()
            _, x, y, _ = s.sim.truth[-1]
            return said, (x, y), s.sim.body.collisions
    finally:
        broker.stop()


async def test_a_vda5050_2_0_master_of_a_third_party_drives_navd_through_an_order(
    tmp_path: Path,
) -> None:
    said, (x, y), collisions = await _run_master(tmp_path, "drive")
    assert said[-1]["event"] == "processed", said
    assert said[-1]["error"] is None and not said[-1]["byCancelation"], said
    traversed = [line["nodeId"] for line in said if line["event"] == "node"]
    assert traversed[-2:] == ["door", "corridor"], said
    assert math.hypot(x - ROUTE[-1][1], y - ROUTE[-1][2]) < 0.5
    assert collisions == 0


async def test_a_third_party_master_updates_pauses_resumes_and_cancels_an_order(
    tmp_path: Path,
) -> None:
    said, (x, _), collisions = await _run_master(tmp_path, "lifecycle")
    steps = [
        (line["event"], line.get("label") or line.get("actionType"), line.get("status"))
        for line in said
        if line["event"] in ("processed", "updated", "action")
        and line.get("status") in (None, "FINISHED", "FAILED")
    ]
    assert steps[:4] == [
        ("processed", "order", None),  # the base driven: the order waits at the door
        ("updated", None, None),
        ("action", "startPause", "FINISHED"),  # once the robot stands
        ("action", "stopPause", "FINISHED"),
    ], said
    # the cancel's end and the order's (cancelled) come in one state: heard in either order
    assert sorted(steps[4:]) == [
        ("action", "cancelOrder", "FINISHED"),
        ("processed", "update", None),
    ]
    first, last = [line for line in said if line["event"] == "processed"]
    assert first["active"] and first["error"] is None  # the horizon still to come
    assert last["byCancelation"] and last["error"] is None
    assert x < ROUTE[-1][1] - 0.5  # cancelled on the way: the corridor's end not reached
    assert collisions == 0
