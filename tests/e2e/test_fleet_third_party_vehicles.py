"""navd's fleet control driving vehicles it was not written with: three VDA 5050 2.0
vehicles of vda-5050-lib (npm; its AgvController with its virtual vehicle, validating every
message against its own 2.0 schemas and refusing what fails) on a real mosquitto are sent a
group goal with the real ``navd fleet goal``. Spoken to in 2.1, or with a start action that
is not a standard one, they refuse the first order; in 2.0 with standard orders only, they
form up, start together and reach the triangle at the goal."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import pytest

from tests.e2e.conftest import run_navd
from tests.e2e.test_fleet_third_party_master import JS, _master_or_skip
from tests.fleet.broker import Broker

pytestmark = pytest.mark.e2e

VEHICLES = [["v1", 0.0, 0.0], ["v2", 0.0, 1.5], ["v3", 1.3, 0.75]]
GOAL = (5.0, 0.75)
SPACING_M = 1.0


def _navd_fleet(*args: str) -> subprocess.CompletedProcess[str]:
    return run_navd("fleet", *args, timeout_s=300.0)


def test_navd_fleet_drives_third_party_2_0_vehicles_to_a_group_goal(tmp_path: Path) -> None:
    node = _master_or_skip()
    broker = Broker(tmp_path)
    broker.start()
    errors = (tmp_path / "vehicles.err").open("wb")
    vehicles = subprocess.Popen(
        [node, str(JS / "vda5050_vehicles.js"), broker.url, "map", json.dumps(VEHICLES)],
        cwd=JS,
        stdout=subprocess.PIPE,
        stderr=errors,
        text=True,
    )
    try:
        assert vehicles.stdout is not None
        assert json.loads(vehicles.stdout.readline()) == {"event": "ready", "vehicles": 3}
        x, y = GOAL
        drive = _navd_fleet(
            "goal", str(x), str(y), "--spacing", str(SPACING_M), "--timeout", "120",
            "--broker", broker.url,
        )  # fmt: skip
        assert drive.returncode == 0, drive.stdout + drive.stderr
        summary = json.loads(drive.stdout)
        assert summary["reached"] is True
        for member in summary["members"]:
            assert member["last_place"] == member["of"] and not member["paused"]
            assert member["errors"] == []
        said = [json.loads(line) for line in drive.stderr.splitlines() if line.startswith("{")]
        assert [e["event"] for e in said][:2] == ["sent", "started"]  # held, then let go
        # where the vehicles themselves say they stand: a triangle of 1 m sides at the goal
        status = _navd_fleet("status", "--broker", broker.url)
        assert status.returncode == 0, status.stderr
        at = [(v["x"], v["y"]) for v in json.loads(status.stdout)["vehicles"]]
        centre = (sum(p[0] for p in at) / 3, sum(p[1] for p in at) / 3)
        assert math.dist(centre, GOAL) < 0.3
        sides = sorted(math.dist(a, b) for i, a in enumerate(at) for b in at[i + 1 :])
        assert sides == pytest.approx([SPACING_M] * 3, abs=0.3)
    finally:
        vehicles.kill()
        vehicles.wait()
        errors.close()
        broker.stop()
