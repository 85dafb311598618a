"""The simulated robot in its world: the body, the people walking about, the wheel commands
the chassis received, and the truth. Pure: it is stepped by whoever owns the time.

The chassis end behaves like the firmware should: each "%d %d" line becomes a commanded body
velocity through the robot's calibration, and the motors stop when no line came for
``COMMAND_TIMEOUT_S``. Measured wheel speeds go back as "%d %d" encoder lines.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from navd.config import NavdConfig
from navd.drivers import WheelCalibration
from navd.geometry import Footprint, Pose2
from navd.sim.body import Body, command_velocity, encode_wheels
from navd.sim.world import World

__all__ = ["COMMAND_TIMEOUT_S", "SimRobot", "WheelInput"]

COMMAND_TIMEOUT_S = 0.5
MOVER_GAP_M = 0.05
MAX_PENDING_BYTES = 256  # a wheel line is a few bytes; more without a newline is garbage
TRUTH_PERIOD_S = 0.1


@dataclass
class WheelInput:
    """The wheel command lines the chassis received.

    Attributes:
        command: [m/s, rad/s] the body velocity the last good line asked for.
        commanded_at: [s] when it came.
        lines, bad_lines: good and unreadable lines so far.
        log: every good line: (sim time [s], left, right).
    """

    command: tuple[float, float] = (0.0, 0.0)
    commanded_at: float = -math.inf
    lines: int = 0
    bad_lines: int = 0
    log: list[tuple[float, int, int]] = field(default_factory=list)
    pending: bytearray = field(default_factory=bytearray)


def _nobody() -> npt.NDArray[np.float64]:
    return np.empty((0, 3))


class SimRobot:
    """One simulated robot in ``world``, set up by ``config`` (robot, chassis, lidar mount).

    Args:
        world: what the robot lives in.
        config: the daemon's config (footprint, calibration, limits).
    """

    def __init__(self, world: World, config: NavdConfig, start: Pose2 | None = None) -> None:
        self.world = world
        self.config = config
        self.footprint = Footprint.of(config.robot)
        self.calibration = WheelCalibration.of(config.chassis)
        x, y, yaw = start if start is not None else world.start
        self.body = Body(x, y, yaw)
        # Other robots in the same world, as K x 3 (x, y, radius) discs [m]: the lidar sees
        # them and the body collides with them (a fleet simulated together).
        self.neighbours: Callable[[], npt.NDArray[np.float64]] = _nobody
        self.wheels = WheelInput()
        self.truth: list[tuple[float, float, float, float]] = []
        self.last_accel = (0.0, 0.0)  # [m/s^2] forward, and centripetal (v * w)
        # Each mover's own clock [s]: it stands still while going on would touch the robot.
        self._mover_t = np.zeros(len(world.movers))
        self._mover_dir = np.ones(len(world.movers))

    def take_wheel_bytes(self, data: bytes, now: float) -> None:
        """Bytes from the chassis UART at ``now`` [s]: each "%d %d" line is a command."""
        wheels = self.wheels
        wheels.pending.extend(data)
        while (end := wheels.pending.find(b"\n")) >= 0:
            line = bytes(wheels.pending[:end])
            del wheels.pending[: end + 1]
            try:
                left, right = (int(v) for v in line.strip().split())
            except ValueError:
                wheels.bad_lines += 1
                continue
            wheels.command = command_velocity(left, right, self.config)
            wheels.commanded_at = now
            wheels.lines += 1
            wheels.log.append((now, left, right))
        if len(wheels.pending) > MAX_PENDING_BYTES:
            wheels.pending.clear()
            wheels.bad_lines += 1

    def encoder_line(self) -> bytes:
        """The "%d %d" encoder report of the wheels' measured speeds."""
        left, right = encode_wheels(
            *self.body.wheels(self.config.robot.track_width_m), self.calibration
        )
        return b"%d %d\n" % (left, right)

    def step(self, now: float, dt: float) -> None:
        """Move the movers and the body over ``dt`` [s] at time ``now`` [s]."""
        command = self.wheels.command
        if now - self.wheels.commanded_at > COMMAND_TIMEOUT_S:
            command = (0.0, 0.0)  # the firmware's own watchdog
        v0, w0 = self.body.linear_mps, self.body.angular_radps
        self.advance_movers(dt)
        self.body.step(dt, command, self.config, self.world, self.discs())
        if dt > 0:
            self.last_accel = ((self.body.linear_mps - v0) / dt, v0 * w0)
        if not self.truth or now >= self.truth[-1][0] + TRUTH_PERIOD_S - 1e-9:
            self.truth.append((now, self.body.x_m, self.body.y_m, self.body.yaw_rad))

    def discs(self) -> npt.NDArray[np.float64]:
        """K x 3 (x, y, radius) [m] of the moving discs now: the movers, then the other
        robots of a fleet."""
        others = self.neighbours()
        if not self.world.movers:
            return others
        movers = np.array(
            [
                (*m.position(t), m.radius_m)
                for m, t in zip(self.world.movers, self._mover_t, strict=True)
            ]
        )
        return movers if others.shape[0] == 0 else np.vstack([movers, others])

    def advance_movers(self, dt: float) -> None:
        """Advance each mover; one whose next step would come within MOVER_GAP_M of the robot
        turns back instead: movers are people, who do not walk into a robot."""
        b = self.body
        for i, mover in enumerate(self.world.movers):
            t = self._mover_t[i] + self._mover_dir[i] * dt
            x, y = mover.position(t)
            gap = math.hypot(x - b.x_m, y - b.y_m) - self.footprint.circumradius_m - mover.radius_m
            if gap >= MOVER_GAP_M:
                self._mover_t[i] = t
            else:
                self._mover_dir[i] = -self._mover_dir[i]
