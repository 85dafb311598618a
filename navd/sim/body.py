"""The simulated robot body: a differential drive that follows wheel commands like a motor
controller would (acceleration-limited), stopped by walls instead of passing through them,
and at the brink of a drop (a robot whose wheel or caster would have gone over it is
counted as fallen)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.config import NavdConfig, RobotConfig
from navd.drivers import WheelCalibration, body_velocity, wheel_speeds
from navd.geometry import Footprint, wrap_angle
from navd.sim._sim_kernels import footprint_contact
from navd.sim.world import World

__all__ = ["Body", "decode_wheels", "encode_wheels"]

CASTER_REACH = 0.5  # a caster stands this share of the way from the centre to the outline


def decode_wheels(left: int, right: int, cal: WheelCalibration) -> tuple[float, float]:
    """[m/s] (left, right) wheel speeds the STM32 would drive for a "%d %d" command."""
    left_mps = (-left if cal.invert_left else left) / cal.scale_per_mps
    right_mps = (-right if cal.invert_right else right) / cal.scale_per_mps
    return left_mps, right_mps


def encode_wheels(left_mps: float, right_mps: float, cal: WheelCalibration) -> tuple[int, int]:
    """The "%d %d" encoder report of measured wheel speeds [m/s] (no deadband or limit)."""
    left = round(left_mps * cal.scale_per_mps)
    right = round(right_mps * cal.scale_per_mps)
    return (-left if cal.invert_left else left), (-right if cal.invert_right else right)


@dataclass
class Body:
    """The robot's true state.

    Attributes:
        x_m, y_m, yaw_rad: pose in the world.
        linear_mps, angular_radps: actual body velocity.
        collisions: how many steps the body was held back by an obstacle.
        falls: how many steps the body would have gone over a drop.
        min_clearance_m: smallest clearance of the footprint to the world so far.
    """

    x_m: float
    y_m: float
    yaw_rad: float
    linear_mps: float = 0.0
    angular_radps: float = 0.0
    collisions: int = 0
    falls: int = 0
    min_clearance_m: float = math.inf

    def step(
        self,
        dt_s: float,
        command: tuple[float, float],
        config: NavdConfig,
        world: World,
        discs: npt.NDArray[np.float64],
    ) -> None:
        """Move for ``dt_s`` towards the commanded (v, ω), within the acceleration limits;
        a move that would overlap the world is refused (the robot bumps and stops)."""
        robot = config.robot
        dv = robot.max_linear_accel_mps2 * dt_s
        dw = robot.max_angular_accel_radps2 * dt_s
        v = self.linear_mps + min(max(command[0] - self.linear_mps, -dv), dv)
        w = self.angular_radps + min(max(command[1] - self.angular_radps, -dw), dw)
        yaw = self.yaw_rad + w * dt_s
        if abs(w) < 1e-9:
            x = self.x_m + v * dt_s * math.cos(self.yaw_rad)
            y = self.y_m + v * dt_s * math.sin(self.yaw_rad)
        else:
            x = self.x_m + v / w * (math.sin(yaw) - math.sin(self.yaw_rad))
            y = self.y_m - v / w * (math.cos(yaw) - math.cos(self.yaw_rad))
        fp = Footprint.of(robot)
        if world.drops is not None and _over(world, world.drops, robot, (x, y, yaw)):
            self.falls += 1
            self.linear_mps = self.angular_radps = 0.0
            return
        clearance = footprint_contact(
            world.solid,
            world.origin_x_m,
            world.origin_y_m,
            world.resolution_m,
            x,
            y,
            yaw,
            fp.kind,
            fp.half_length_m,
            fp.half_width_m,
            discs,
        )
        if clearance < 0.0:
            self.collisions += 1
            self.linear_mps = self.angular_radps = 0.0
            self.min_clearance_m = min(self.min_clearance_m, clearance)
            return
        self.x_m, self.y_m = x, y
        self.yaw_rad = wrap_angle(yaw)
        self.linear_mps, self.angular_radps = v, w
        self.min_clearance_m = min(self.min_clearance_m, clearance)

    def wheels(self, track_width_m: float) -> tuple[float, float]:
        """[m/s] the actual (left, right) wheel speeds."""
        return wheel_speeds(self.linear_mps, self.angular_radps, track_width_m)


def _over(
    world: World, cells: npt.NDArray[np.bool_], robot: RobotConfig, pose: tuple[float, float, float]
) -> bool:
    """Whether a point the robot stands on at ``pose`` (x, y, yaw) lies on ``cells``: its
    centre, its two wheels, and a caster ``CASTER_REACH`` of the way to its front and back
    (an outline overhanging a step is not a fall; a wheel or caster over it is)."""
    x, y, yaw = pose
    half_track, reach = robot.track_width_m / 2.0, CASTER_REACH * Footprint.of(robot).half_length_m
    local = np.array(
        [[0.0, 0.0], [0.0, half_track], [0.0, -half_track], [reach, 0.0], [-reach, 0.0]]
    )
    c, s = math.cos(yaw), math.sin(yaw)
    px = x + c * local[:, 0] - s * local[:, 1]
    py = y + s * local[:, 0] + c * local[:, 1]
    cols = np.floor((px - world.origin_x_m) / world.resolution_m).astype(np.int64)
    rows = np.floor((py - world.origin_y_m) / world.resolution_m).astype(np.int64)
    inside = (rows >= 0) & (rows < cells.shape[0]) & (cols >= 0) & (cols < cells.shape[1])
    return bool(cells[rows[inside], cols[inside]].any())


def command_velocity(left: int, right: int, config: NavdConfig) -> tuple[float, float]:
    """[m/s, rad/s] the body velocity a "%d %d" wheel command asks for."""
    cal = WheelCalibration.of(config.chassis)
    return body_velocity(*decode_wheels(left, right, cal), config.robot.track_width_m)
