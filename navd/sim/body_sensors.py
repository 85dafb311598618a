"""What the simulated robot's other sensors measure: a range sensor for each
``mounts.ranges`` entry, a bumper or cliff sensor for each ``mounts.contacts`` entry (a
name starting with "cliff" is a cliff sensor), a depth camera for each ``mounts.depth``
entry, and a battery. Each has a connection of its own (device id ``sim-NAME``).

- A range sensor casts a few rays across its cone against what it hears (the world and the
  glass) and reports the nearest, with noise; nothing within reach is ``null``.
- A bumper is pressed while something the body cannot enter is within ``BUMP_M`` of its
  point (its shell touches and gives); a cliff sensor sees no floor while its point is over
  a drop.
- A depth camera casts a fan of rays at heights through its band: at each height, what
  stands there (walls and boxes always, low boxes below ``LOW_HEIGHT_M``, table tops between
  ``TABLE_UNDERSIDE_M`` and ``TABLE_TOP_M``); the points go in the camera's body axes.
- The battery drains at its idle power and more in proportion to the speed.
"""

from __future__ import annotations

import base64
import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from navd.config import NavdConfig
from navd.geometry import Pose2, SensorMounts
from navd.sim._sim_kernels import cast_rays
from navd.sim.physics import SimRobot
from navd.sim.settings import SimSettings
from navd.sim.world import LOW_HEIGHT_M, TABLE_TOP_M, TABLE_UNDERSIDE_M, World
from navd.wire import BatteryFrame, ContactFrame, PointsFrame, RangeFrame, Role, SensorFrame

__all__ = ["BUMP_M", "BodySensors"]

BUMP_M = 0.02  # [m] a bumper shell touching something gives this much before it switches
CONE_RAYS = 5
DEPTH_HEIGHTS_M = (0.05, 0.15, 0.3, 0.45, 0.68, 0.9)  # sampled through a camera's band
BoolArray = npt.NDArray[np.bool_]
Source = tuple[Role, str, float, Callable[[float], SensorFrame]]


class BodySensors:
    """The frames of the robot's other sensors (see the module docstring).

    Args:
        robot: the simulated robot (read, never moved).
        config: the daemon's config (the mounts).
        settings: rates and noises.
        rng: the simulator's seeded noise.
    """

    def __init__(
        self, robot: SimRobot, config: NavdConfig, settings: SimSettings, rng: np.random.Generator
    ) -> None:
        self.robot, self.settings, self._rng = robot, settings, rng
        self.mounts = SensorMounts.of(config.mounts, config.lidar).body
        self._depth_mounts = config.mounts.depth
        self._charge_wh = settings.battery_wh
        self._battery_at: float | None = None
        world = robot.world
        self._heard = world.grid if world.glass is None else world.grid | world.glass

    def frames(self) -> list[Source]:
        """(role, device id, rate [Hz], frame of a time [s]) of each sensor."""
        s, m = self.settings, self.mounts
        out: list[Source] = []
        out += [("range", f"sim-{n}", s.range_rate_hz, self._sonar_of(n)) for n in m.ranges]
        out += [("contact", f"sim-{n}", s.contact_rate_hz, self._contact_of(n)) for n in m.contacts]
        out += [("points", f"sim-{n}", s.depth_rate_hz, self._depth_of(n)) for n in m.depth]
        if s.battery_rate_hz > 0:
            out.append(("battery", "sim-battery", s.battery_rate_hz, self.battery))
        return out

    def _sonar_of(self, name: str) -> Callable[[float], SensorFrame]:
        return lambda now: self.sonar(name, now)

    def _contact_of(self, name: str) -> Callable[[float], SensorFrame]:
        return lambda now: self.contact(name, now)

    def _depth_of(self, name: str) -> Callable[[float], SensorFrame]:
        return lambda now: self.depth(name, now)

    def _at(self, mount: Pose2) -> Pose2:
        b = self.robot.body
        return Pose2(b.x_m, b.y_m, b.yaw_rad).compose(mount)

    def sonar(self, name: str, now: float) -> RangeFrame:
        """The nearest thing the range sensor ``name`` hears in its cone."""
        s, w = self.settings, self.robot.world
        where = self._at(self.mounts.ranges[name])
        half = math.radians(s.range_fov_deg) / 2.0
        angles = where.yaw + np.linspace(-half, half, CONE_RAYS)
        ranges = cast_rays(
            self._heard, w.origin_x_m, w.origin_y_m, w.resolution_m, where.x, where.y,
            angles, s.range_max_m, self.robot.discs(),
        )  # fmt: skip
        nearest = float(ranges.min()) + float(self._rng.normal(0.0, s.range_noise_m))
        return RangeFrame(
            stamp=now,
            sensor=name,
            range=round(max(nearest, 0.02), 3) if nearest <= s.range_max_m else None,
            field_of_view=2.0 * half,
            max_range=s.range_max_m,
        )

    def contact(self, name: str, now: float) -> ContactFrame:
        """The state of bumper or cliff sensor ``name``."""
        mount = self.mounts.contacts[name]
        world = self.robot.world
        point = self._at(Pose2(mount.x_m, mount.y_m, 0.0))
        if name.startswith("cliff"):
            return ContactFrame(
                stamp=now, sensor=name, kind="cliff", triggered=_on(world, world.drops, point)
            )
        pressed = _near(world, world.solid, point, BUMP_M)
        return ContactFrame(stamp=now, sensor=name, kind="bumper", triggered=pressed)

    def depth(self, name: str, now: float) -> PointsFrame:
        """What depth camera ``name`` sees through its band, in its body axes."""
        s, w = self.settings, self.robot.world
        spec = self._depth_mounts[name]
        where = self._at(Pose2(spec.x_m, spec.y_m, spec.yaw_rad))
        half = math.radians(s.depth_fov_deg) / 2.0
        bearings = np.linspace(-half, half, s.depth_rays)
        points = []
        for z in DEPTH_HEIGHTS_M:
            if not spec.min_height_m <= z <= spec.max_height_m:
                continue
            grid = w.grid
            if w.low is not None and z <= LOW_HEIGHT_M:
                grid = grid | w.low
            if w.tables is not None and TABLE_UNDERSIDE_M <= z <= TABLE_TOP_M:
                grid = grid | w.tables
            ranges = cast_rays(
                grid, w.origin_x_m, w.origin_y_m, w.resolution_m, where.x, where.y,
                where.yaw + bearings, spec.max_range_m, self.robot.discs(),
            )  # fmt: skip
            seen = np.isfinite(ranges)
            r, a = ranges[seen], bearings[seen]
            points.append(
                np.column_stack([r * np.cos(a), r * np.sin(a), np.full(r.size, z - spec.z_m)])
            )
        xyz = np.concatenate(points) if points else np.empty((0, 3))
        # in the camera's body axes: undo its pitch and roll (its yaw is in ``where``)
        tilt = _rotation_rp(spec.roll_rad, spec.pitch_rad)
        camera = (xyz @ tilt).astype("<f4")
        return PointsFrame(
            stamp=now, sensor=name, frame="body",
            points_f32=base64.b64encode(camera.tobytes()).decode("ascii"),
        )  # fmt: skip

    def battery(self, now: float) -> BatteryFrame:
        """The battery, drained since the last reading."""
        s, body = self.settings, self.robot.body
        if self._battery_at is not None:
            speed = abs(body.linear_mps) / max(self.robot.config.robot.max_linear_speed_mps, 1e-6)
            watts = s.battery_idle_w + s.battery_drive_w * min(speed, 1.0)
            self._charge_wh = max(self._charge_wh - watts * (now - self._battery_at) / 3600.0, 0.0)
        self._battery_at = now
        charge = self._charge_wh / s.battery_wh
        volts = 3 * (3.3 + 0.9 * charge)  # a 3-cell Li-ion pack, near enough
        return BatteryFrame(
            stamp=now, voltage=round(volts, 3), current=-round(s.battery_idle_w / volts, 3),
            percentage=round(charge, 4), charging=False,
        )  # fmt: skip


def _rotation_rp(roll: float, pitch: float) -> npt.NDArray[np.float64]:
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    rotation: npt.NDArray[np.float64] = ry @ rx
    return rotation


def _cell(world: World, x: float, y: float) -> tuple[int, int]:
    res = world.resolution_m
    return math.floor((y - world.origin_y_m) / res), math.floor((x - world.origin_x_m) / res)


def _on(world: World, cells: BoolArray | None, point: Pose2) -> bool:
    if cells is None:
        return False
    row, col = _cell(world, point.x, point.y)
    return 0 <= row < cells.shape[0] and 0 <= col < cells.shape[1] and bool(cells[row, col])


def _near(world: World, cells: BoolArray, point: Pose2, radius_m: float) -> bool:
    res = world.resolution_m
    row, col = _cell(world, point.x, point.y)
    k = math.ceil(radius_m / res)
    window = cells[max(row - k, 0) : row + k + 1, max(col - k, 0) : col + k + 1]
    return bool(window.any())
