"""``navd bench fleet``: ``navd fleet goal`` driving many vehicles through one broker.

Starts mosquitto on a free port, and in this process ``vehicles`` lightweight VDA 5050
vehicles: each is navd's own order logic (``navd.fleet.vehicle.Vehicle``) and state
messages on its own MQTT connection, with a point robot driving to each node at 1 m/s
instead of a daemon and a simulator (the protocol side only). Then it runs ``navd fleet
goal`` as a separate process, as a user would, and prints:

- ``fleet_cpu_percent``: the fleet control's CPU time over its wall time, % of one core;
- ``step_latency_ms_p50`` / ``_p99``: from the publishing of the last vehicle's state that
  completed a step to each vehicle receiving the order update that releases the next
  (state to command, through the broker and the fleet control);
- ``broker_messages_per_s``: every message through the broker while the group drove;
- ``reached``, ``steps``, ``seconds``;
- ``goals``: two goals in a row (there and back), each reached or not with its time, and
  ``left_paused``: the vehicles that still hold their order paused after it (as the
  vehicles themselves say: none may be).
The other figures are the first goal's.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import aiomqtt

from navd.fleet import Broker, Topics, Vehicle, connect, reports
from navd.lifecycle import percentile
from navd.lifecycle.messages import CancelGoal, Goal, GoalStatus
from navd.sim import LocalBroker

__all__ = ["run"]

SPEED_MPS = 1.0  # the point robots' speed
TICK_S = 0.1
VIEW_EVERY_S = 0.5  # their visualization rate (2 Hz, navd's default)


class _PointVehicle:
    """A VDA 5050 vehicle without a robot: navd's order logic, a point driving to goals."""

    def __init__(self, serial: str, x: float, y: float, stamps: dict[str, Any]) -> None:
        self.serial = serial
        self.topics = Topics("uagv", "navd", serial)
        self.vehicle = Vehicle("navd", serial, self._asked)
        self.x, self.y, self.yaw, self.speed = x, y, 0.0, 0.0
        self.goal: Goal | None = None
        self.stamps = stamps  # shared: when steps completed and updates arrived
        self.headers = 0
        self.due = True
        self._told_seq = -1  # the last node the published state has said is reached

    def _asked(self, what: str) -> None:
        self.due = True

    def _robot(self) -> reports.Robot:
        return reports.Robot((self.x, self.y, self.yaw), 0.02, (self.speed, 0.0), (), False, "map")

    def _json(self, build: Any, *args: Any) -> str:
        self.headers += 1
        head = reports.header(self.headers, time.time(), "navd", self.serial)
        return json.dumps(build(head, *args))

    async def run(self, port: int, stop: asyncio.Event) -> None:
        async with connect(Broker("127.0.0.1", port), f"bench-{self.serial}") as client:
            await client.subscribe(self.topics.order, qos=1)
            await client.subscribe(self.topics.instant_actions, qos=1)
            await client.publish(
                self.topics.connection, self._json(reports.connection, "ONLINE"), retain=True
            )
            listen = asyncio.create_task(self._listen(client))
            last_view = 0.0
            try:
                while not stop.is_set():
                    now = time.monotonic()
                    self._move(now)
                    if self.vehicle.changed or self.due:
                        self.vehicle.changed = self.due = False
                        await client.publish(
                            self.topics.state,
                            self._json(reports.state, self.vehicle, self._robot()),
                            qos=1,
                        )
                        seq = self.vehicle.last_node_sequence_id
                        if seq != self._told_seq:  # the state that says a place is reached
                            self._told_seq = seq
                            self.stamps.setdefault(f"done:{seq}", []).append(time.monotonic())
                    if now - last_view >= VIEW_EVERY_S:
                        last_view = now
                        await client.publish(
                            self.topics.visualization,
                            self._json(reports.visualization, self._robot()),
                        )
                    await asyncio.sleep(TICK_S)
            finally:
                listen.cancel()

    async def _listen(self, client: aiomqtt.Client) -> None:
        async for message in client.messages:
            raw = bytes(message.payload)
            now = time.monotonic()
            if str(message.topic) == self.topics.order:
                update = json.loads(raw).get("orderUpdateId", 0)
                if update > 0:
                    self.stamps.setdefault(f"got:{update}", []).append(now)
                out = self.vehicle.on_order(raw, now, None if self.goal else _pose(self))
            else:
                out = self.vehicle.on_instant_actions(raw, now, _pose(self))
            for m in out:
                if isinstance(m, Goal):
                    self.goal = m
                elif isinstance(m, CancelGoal) and self.goal and m.goal_id == self.goal.goal_id:
                    self.goal = None  # a pause

    def _move(self, now: float) -> None:
        for m in self.vehicle.on_tick(now):  # a wait ended, or a retry
            if isinstance(m, Goal):
                self.goal = m
        goal = self.goal
        if goal is None:
            self.speed = 0.0
            return
        dx, dy = goal.x_m - self.x, goal.y_m - self.y
        distance = math.hypot(dx, dy)
        step = SPEED_MPS * TICK_S
        if distance <= step:
            self.x, self.y, self.speed = goal.x_m, goal.y_m, 0.0
            self.goal = None
            reached = GoalStatus(stamp=now, received=now, goal_id=goal.goal_id, state="reached")
            for m in self.vehicle.on_goal_status(reached, now):
                if isinstance(m, Goal):
                    self.goal = m
        else:
            self.yaw = math.atan2(dy, dx)
            self.x += step * dx / distance
            self.y += step * dy / distance
            self.speed = SPEED_MPS


def _pose(v: _PointVehicle) -> Any:
    from navd.geometry import Pose2  # noqa: PLC0415

    return Pose2(v.x, v.y, v.yaw)


async def _count(port: int, stop: asyncio.Event, counter: list[int]) -> None:
    async with connect(Broker("127.0.0.1", port), "bench-counter") as client:
        await client.subscribe("uagv/#", qos=0)
        async for _ in client.messages:
            counter[0] += 1
            if stop.is_set():
                return


def _cpu_s(pid: int) -> float:
    """[s] user + system CPU time of process ``pid`` so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


async def _bench(vehicles: int, broker: str, port: int) -> dict[str, Any]:
    stamps: dict[str, Any] = {}
    side = math.ceil(math.sqrt(vehicles))
    fleet = [
        _PointVehicle(f"v{k:03d}", 1.0 * (k % side), 1.0 * (k // side), stamps)
        for k in range(vehicles)
    ]
    stop = asyncio.Event()
    counter = [0]
    tasks = [asyncio.create_task(v.run(port, stop)) for v in fleet]
    tasks.append(asyncio.create_task(_count(port, stop, counter)))
    await asyncio.sleep(2.0)  # every vehicle online and with a state
    began = time.monotonic()
    counted_from = counter[0]
    # two goals in a row, there and back: the second starts from where the first left them
    goals = [(side / 2.0 + 12.0, side / 2.0), (side / 2.0, side / 2.0)]
    runs = []
    for x, y in goals:
        stamps.clear()
        run = await _goal(broker, x, y)
        run["left_paused"] = await _left_paused(fleet)
        run.update(_latencies(stamps, vehicles))
        runs.append(run)
    wall = time.monotonic() - began
    messages = counter[0] - counted_from
    stop.set()
    for task in tasks:
        task.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)
    first = runs[0]
    return {
        "vehicles": vehicles,
        "reached": all(r["reached"] for r in runs),
        "goals": runs,
        "left_paused": max(r["left_paused"] for r in runs),
        "steps": first["steps"],
        "seconds": first["seconds"],
        "fleet_cpu_percent": first["fleet_cpu_percent"],
        "step_latency_ms_p50": first["step_latency_ms_p50"],
        "step_latency_ms_p99": first["step_latency_ms_p99"],
        "broker_messages_per_s": round(messages / wall, 1) if wall > 0 else None,
    }


async def _left_paused(fleet: list[_PointVehicle], settle_s: float = 3.0) -> int:
    """How many vehicles still hold their order paused, as they say themselves, once the
    fleet control's last messages (sent before it exited) have had ``settle_s`` [s] to
    arrive."""
    deadline = time.monotonic() + settle_s
    while (paused := sum(v.vehicle.paused for v in fleet)) and time.monotonic() < deadline:
        await asyncio.sleep(0.1)
    return paused


async def _goal(broker: str, x: float, y: float) -> dict[str, Any]:
    """One ``navd fleet goal`` to (x, y): reached, its wall time and CPU."""
    command = [
        sys.executable, "-m", "navd", "fleet", "goal", str(x), str(y),
        "--formation", "triangle", "--spacing", "1.2", "--step", "3", "--speed", "1.0",
        "--broker", broker, "--timeout", "300",
    ]  # fmt: skip
    began = time.monotonic()
    proc = await asyncio.create_subprocess_exec(
        *command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL
    )
    cpu = 0.0
    while proc.returncode is None:
        with contextlib.suppress(OSError, IndexError):  # it may have just ended
            cpu = _cpu_s(proc.pid)
        try:
            await asyncio.wait_for(proc.wait(), 0.2)
        except TimeoutError:
            continue
    wall = time.monotonic() - began
    out = (await proc.stdout.read()).decode() if proc.stdout else ""
    summary = json.loads(out.strip().splitlines()[-1]) if out.strip() else {"reached": False}
    return {
        "reached": bool(summary.get("reached")),
        "seconds": round(wall, 1),
        "fleet_cpu_percent": round(100.0 * cpu / wall, 1) if wall > 0 else None,
    }


def _latencies(stamps: dict[str, Any], vehicles: int) -> dict[str, Any]:
    """Steps released, and state-to-update latencies [ms]: update 1 releases the form-up
    place at the start time; update u >= 2 releases place u - 1 once all have said they
    reached place u - 2 (node sequence id 2 (u - 1))."""
    latencies = []
    for key, arrivals in stamps.items():
        update = int(key.split(":")[1]) if key.startswith("got:") else 0
        done = stamps.get(f"done:{2 * (update - 1)}", []) if update >= 2 else []
        if len(done) == vehicles:
            latencies += [1e3 * (t - max(done)) for t in arrivals]
    return {
        "steps": len([k for k in stamps if k.startswith("got:")]) - 1,
        "step_latency_ms_p50": round(percentile(latencies, 50), 1) if latencies else None,
        "step_latency_ms_p99": round(percentile(latencies, 99), 1) if latencies else None,
    }


def run(vehicles: int = 50) -> dict[str, Any]:
    """The figures (see the module docstring).

    Raises:
        SimError: mosquitto is not installed.
    """
    with tempfile.TemporaryDirectory() as folder:
        broker = LocalBroker(Path(folder))
        broker.start()
        try:
            return asyncio.run(_bench(vehicles, broker.url, broker.port))
        finally:
            broker.stop()
