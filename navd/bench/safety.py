"""``navd bench safety``: how soon the wheels stop when a sensor the estimate depends on
falls silent or goes away.

The real daemon (``navd run`` on the shipped defaults: uvloop, the tcp timeouts, the safety
gate) drives the simulated robot in real time along a 40 m hall, its lidar and IMU over real
TCP, its chassis on a real pseudo-terminal. In each trial, once the robot drives at
``MOVING_MPS`` or more, one sensor stops: the lidar falls silent while staying connected
(a hung driver), the lidar is unplugged, the IMU falls silent, or is unplugged. The figure is
the time from the sensor's last frame to the first "0 0" line on the chassis UART; then the
sensor comes back and the drive goes on. No peer stack runs here to compare with (Nav2's
collision monitor and robot_localization would need ROS 2), so the figures stand alone,
against the 300 ms the daemon promises.
"""

from __future__ import annotations

import asyncio
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from navd.sim import Session, from_shapes, session
from navd.wire import GoalFrame, InitialPoseFrame

__all__ = ["CASES", "run"]

# (figure name, sensor role, how it stops)
CASES = (
    ("lidar_silent", "lidar", "silent"),
    ("lidar_unplugged", "lidar", "unplugged"),
    ("imu_silent", "imu", "silent"),
    ("imu_unplugged", "imu", "unplugged"),
)
PROMISE_MS = 300.0
MOVING_MPS = 0.2  # [m/s] a trial starts once the robot drives at least this fast
END_X_M = (2.0, 36.0)  # [m] the goals, at either end of the hall
TURN_AROUND_M = 3.0  # [m] this near its goal the robot is sent to the other end
WAIT_S = 20.0  # [s] longest wait for the robot to move, or the wheels to stop
HALL = {
    "walls": [[-1, -1.5, 39, -1.5], [39, -1.5, 39, 1.5], [39, 1.5, -1, 1.5], [-1, 1.5, -1, -1.5]],
    "start": [0.0, 0.0, 0.0],
}


def run(trials: int = 10) -> dict[str, Any]:
    """Run ``trials`` trials of each case; [ms] p50 and worst of each, and whether every
    trial kept the promise."""
    return asyncio.run(_run(trials))


async def _run(trials: int) -> dict[str, Any]:
    world = from_shapes(HALL, "hall")
    figures: dict[str, Any] = {"trials": trials, "promise_ms": PROMISE_MS}
    with tempfile.TemporaryDirectory(prefix="navd-bench-safety-") as folder:
        defaults = {"lifecycle": {"event_loop": "uvloop"}}
        async with session(world, Path(folder), overrides=defaults) as s:
            s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
            goal = _Goal(s)
            worst = 0.0
            for name, role, how in CASES:
                delays = [await _trial(s, goal, role, how) for _ in range(trials)]
                worst = max(worst, *delays)
                figures[f"{name}_p50_ms"] = round(statistics.median(delays), 1)
                figures[f"{name}_max_ms"] = round(max(delays), 1)
                figures[f"{name}_ms"] = [round(d, 1) for d in delays]
            figures["all_within_promise"] = worst <= PROMISE_MS
    return figures


class _Goal:
    """Keeps the robot driving from one end of the hall to the other."""

    def __init__(self, s: Session) -> None:
        self.s = s
        self.target = 1
        self.sent = 0

    async def keep_going(self) -> None:
        body = self.s.sim.body
        if self.sent == 0 or abs(body.x_m - END_X_M[self.target]) < TURN_AROUND_M:
            if self.sent:
                self.target = 1 - self.target
            self.sent += 1
            x = END_X_M[self.target]
            await self.s.control.request(GoalFrame(x=x, y=0.0, goal_id=f"leg{self.sent}"))


async def _trial(s: Session, goal: _Goal, role: str, how: str) -> float:
    """[ms] from the sensor's last frame to the first "0 0" after it stopped."""
    sim, models = s.sim, s.sim.sensors
    sensor = models.sensor(role)  # type: ignore[arg-type]
    log = sim.robot.wheels.log
    back = sim.now()

    def driving() -> bool:
        # the sensor speaks again, the chassis was told to move since, and the robot does
        return (
            sensor.last_sent_s > back
            and bool(log)
            and log[-1][0] > back
            and log[-1][1:] != (0, 0)
            and sim.body.linear_mps >= MOVING_MPS
        )

    await _until(s, driving, goal)
    control = f"{role}_silent" if how == "silent" else f"{role}_plugged"
    setattr(models, control, how == "silent")
    cut = sim.now()
    try:
        await _until(s, lambda: log[-1][0] >= cut and log[-1][1:] == (0, 0))
        zero = min(t for t, left, right in log if t >= cut and (left, right) == (0, 0))
        return (zero - sensor.last_sent_s) * 1e3
    finally:
        setattr(models, control, how != "silent")


async def _until(s: Session, done: Any, goal: _Goal | None = None) -> None:
    """Wait until ``done()``, keeping the robot's goal alive meanwhile.

    Raises:
        TimeoutError: not within WAIT_S.
    """
    deadline = time.monotonic() + WAIT_S
    while not done():
        s.check()
        if time.monotonic() > deadline:
            raise TimeoutError(f"the simulated robot did not get there within {WAIT_S} s")
        if goal is not None:
            await goal.keep_going()
        await asyncio.sleep(0.005)
