"""The simulator process: it plays the robot through the same interfaces as the hardware.

- The chassis: a pseudo-terminal whose far end is linked at ``tty_link``; the daemon's
  chassis driver opens that path as it would /dev/ttyS0. "%d %d" lines become a commanded body
  velocity through the robot's calibration; like the firmware should, the motors stop when no
  line comes for ``COMMAND_TIMEOUT_S``; measured wheel speeds go back as "%d %d" encoder lines.
- The sensors: TCP clients of the daemon, exactly like external sensor programs: a 2D lidar
  (ray cast against the world, Gaussian range noise) and an IMU (gyro with bias and noise,
  accelerations of the true motion plus gravity). They reconnect if the daemon is not up yet.
- The truth: the body's pose is recorded for scoring.

Real time only; the world runs at ``physics_rate_hz``.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from navd.config import NavdConfig
from navd.drivers.kinematics import WheelCalibration
from navd.drivers.wire import PROTOCOL_VERSION
from navd.planning.footprint import Footprint
from navd.sim._sim_kernels import cast_rays
from navd.sim.body import Body, command_velocity, encode_wheels
from navd.sim.errors import SimError
from navd.sim.world import World

__all__ = ["SimSettings", "Simulator"]

COMMAND_TIMEOUT_S = 0.5
GRAVITY_MPS2 = 9.80665
RECONNECT_S = 0.2
MOVER_GAP_M = 0.05


@dataclass(frozen=True, slots=True)
class SimSettings:
    """How the simulator connects and what its sensors are like.

    Attributes:
        host, port: the daemon's TCP server.
        tty_link: path of the symlink to the chassis end of the pseudo-terminal.
        lidar_beams, lidar_rate_hz, lidar_noise_m, lidar_max_range_m: the 2D lidar.
        imu_rate_hz, gyro_noise_radps, gyro_bias_radps, accel_noise_mps2: the IMU (0 Hz: none).
        gps_rate_hz, gps_noise_m: a GNSS receiver, streaming only when the daemon's config
            has a datum (``world.datum_latitude_deg``/``longitude_deg``, at map (0, 0)).
        physics_rate_hz: world steps per second.
        feedback_rate_hz: encoder lines per second (0: none).
        seed: seeds every noise source.
    """

    host: str = "127.0.0.1"
    port: int = 7420
    tty_link: Path = Path("/tmp/navd-sim-tty")
    lidar_beams: int = 360
    lidar_rate_hz: float = 10.0
    lidar_noise_m: float = 0.01
    lidar_max_range_m: float = 12.0
    imu_rate_hz: float = 100.0
    gyro_noise_radps: float = 0.002
    gyro_bias_radps: float = 0.003
    accel_noise_mps2: float = 0.05
    gps_rate_hz: float = 5.0
    gps_noise_m: float = 1.0
    physics_rate_hz: float = 100.0
    feedback_rate_hz: float = 20.0
    seed: int = 0


@dataclass
class _Drive:
    command: tuple[float, float] = (0.0, 0.0)
    commanded_at: float = -math.inf
    lines: int = 0
    bad_lines: int = 0
    buffer: bytearray = field(default_factory=bytearray)


class Simulator:
    """One simulated robot in ``world``, set up by ``config`` (robot, chassis, slam mount).

    Args:
        world: what the robot lives in.
        config: the daemon's config (footprint, calibration, lidar mount, limits).
        settings: connections and sensors.
    """

    def __init__(self, world: World, config: NavdConfig, settings: SimSettings) -> None:
        self.world = world
        self.config = config
        self.settings = settings
        x, y, yaw = world.start
        self.body = Body(x, y, yaw)
        self.truth: list[tuple[float, float, float, float]] = []
        self.started = time.monotonic()
        self.connected: set[str] = set()
        self._drive = _Drive()
        self._rng = np.random.default_rng(settings.seed)
        self._master = -1
        self._slave = -1
        self._last_accel = (0.0, 0.0)
        self._readers: set[asyncio.Task[None]] = set()
        # Scenario controls: a lidar "unplugged" closes its connection until plugged back.
        self.lidar_plugged = True
        self.gps_plugged = True
        # Each mover's own clock [s]: it stands still while going on would touch the robot.
        self._mover_t = np.zeros(len(world.movers))
        self._mover_dir = np.ones(len(world.movers))
        # Every wheel command line received: (sim time [s], left, right).
        self.wheel_log: list[tuple[float, int, int]] = []

    @property
    def chassis_lines(self) -> int:
        """How many "%d %d" wheel command lines the chassis side received."""
        return self._drive.lines

    def now(self) -> float:
        """[s] simulation time: seconds since the simulator started."""
        return time.monotonic() - self.started

    async def run(self, stop: asyncio.Event) -> None:
        """Play the robot until ``stop`` is set."""
        self._open_pty()
        loop = asyncio.get_running_loop()
        loop.add_reader(self._master, self._readable)
        tasks = [
            asyncio.create_task(self._physics(), name="sim-physics"),
            asyncio.create_task(self._lidar(), name="sim-lidar"),
        ]
        if self.settings.imu_rate_hz > 0:
            tasks.append(asyncio.create_task(self._imu(), name="sim-imu"))
        if self.settings.gps_rate_hz > 0 and self.config.world.datum_latitude_deg is not None:
            tasks.append(asyncio.create_task(self._gps(), name="sim-gps"))
        if self.settings.feedback_rate_hz > 0:
            tasks.append(asyncio.create_task(self._feedback(), name="sim-feedback"))
        try:
            await stop.wait()
        finally:
            for task in tasks:
                task.cancel()
            for task in tasks:
                with contextlib.suppress(asyncio.CancelledError):
                    await task
            loop.remove_reader(self._master)
            self._close_pty()

    # --- chassis ---------------------------------------------------------------------------

    def _open_pty(self) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # bytes pass unchanged in both directions
        os.set_blocking(self._master, False)
        link = self.settings.tty_link
        with contextlib.suppress(FileNotFoundError):
            link.unlink()
        try:
            link.symlink_to(os.ttyname(self._slave))
        except OSError as err:
            raise SimError(f"cannot create the chassis link {link}: {err}") from err

    def _close_pty(self) -> None:
        with contextlib.suppress(FileNotFoundError):
            self.settings.tty_link.unlink()
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)

    def _readable(self) -> None:
        try:
            data = os.read(self._master, 4096)
        except (BlockingIOError, OSError):
            return
        drive = self._drive
        drive.buffer.extend(data)
        while b"\n" in drive.buffer:
            line, _, rest = bytes(drive.buffer).partition(b"\n")
            drive.buffer = bytearray(rest)
            try:
                left, right = (int(v) for v in line.strip().split())
            except ValueError:
                drive.bad_lines += 1
                continue
            drive.command = command_velocity(left, right, self.config)
            drive.commanded_at = self.now()
            drive.lines += 1
            self.wheel_log.append((drive.commanded_at, left, right))
        if len(drive.buffer) > 256:
            drive.buffer.clear()
            drive.bad_lines += 1

    async def _feedback(self) -> None:
        cal = WheelCalibration.from_config(self.config.chassis)
        period = 1.0 / self.settings.feedback_rate_hz
        while True:
            await asyncio.sleep(period)
            left, right = encode_wheels(*self.body.wheels(self.config.robot.track_width_m), cal)
            with contextlib.suppress(BlockingIOError, OSError):
                os.write(self._master, b"%d %d\n" % (left, right))

    # --- world -----------------------------------------------------------------------------

    async def _physics(self) -> None:
        period = 1.0 / self.settings.physics_rate_hz
        last = self.now()
        next_truth = 0.0
        while True:
            await asyncio.sleep(period)
            now = self.now()
            dt = min(now - last, 0.1)
            last = now
            command = self._drive.command
            if now - self._drive.commanded_at > COMMAND_TIMEOUT_S:
                command = (0.0, 0.0)  # the firmware's own watchdog
            v0, w0 = self.body.linear_mps, self.body.angular_radps
            self.advance_movers(dt)
            self.body.step(dt, command, self.config, self.world, self.discs())
            if dt > 0:
                self._last_accel = ((self.body.linear_mps - v0) / dt, v0 * w0)
            if now >= next_truth:
                self.truth.append((now, self.body.x_m, self.body.y_m, self.body.yaw_rad))
                next_truth = now + 0.1

    def discs(self) -> np.ndarray:
        """K x 3 (x, y, radius) [m] of the moving discs now."""
        if not self.world.movers:
            return np.empty((0, 3))
        return np.array(
            [
                (*m.position(t), m.radius_m)
                for m, t in zip(self.world.movers, self._mover_t, strict=True)
            ]
        )

    def advance_movers(self, dt: float) -> None:
        """Advance each mover; one whose next step would come within MOVER_GAP_M of the robot
        turns back instead: movers are people, who do not walk into a robot."""
        fp = Footprint.from_config(self.config.robot)
        b = self.body
        for i, mover in enumerate(self.world.movers):
            t = self._mover_t[i] + self._mover_dir[i] * dt
            x, y = mover.position(t)
            gap = math.hypot(x - b.x_m, y - b.y_m) - fp.circumradius_m - mover.radius_m
            if gap >= MOVER_GAP_M:
                self._mover_t[i] = t
            else:
                self._mover_dir[i] = -self._mover_dir[i]

    # --- sensors ---------------------------------------------------------------------------

    async def _connect(self, role: str, device_id: str) -> asyncio.StreamWriter:
        """A sensor connection after a welcome; retries until the daemon answers."""
        while True:
            try:
                reader, writer = await asyncio.open_connection(
                    self.settings.host, self.settings.port
                )
                hello = {
                    "type": "hello",
                    "protocol": PROTOCOL_VERSION,
                    "role": role,
                    "device_id": device_id,
                }
                writer.write(json.dumps(hello).encode() + b"\n")
                answer = json.loads(await asyncio.wait_for(reader.readline(), 5.0))
                if answer.get("type") == "welcome":
                    self.connected.add(device_id)
                    task = asyncio.get_running_loop().create_task(_drain(reader))
                    self._readers.add(task)
                    task.add_done_callback(self._readers.discard)
                    return writer
                writer.close()
            except (OSError, TimeoutError, ValueError):
                pass
            await asyncio.sleep(RECONNECT_S)

    async def _stream(
        self,
        role: str,
        device_id: str,
        rate_hz: float,
        frame: Callable[[], dict[str, object]],
        plugged: Callable[[], bool] | None = None,
    ) -> None:
        """Send ``frame()`` at ``rate_hz`` on a (re)connected sensor connection, while
        ``plugged()`` (when given) says the device is plugged in."""
        period = 1.0 / rate_hz

        def is_plugged() -> bool:
            return plugged is None or plugged()

        while True:
            while not is_plugged():
                await asyncio.sleep(period)
            writer = await self._connect(role, device_id)
            try:
                while is_plugged():
                    await asyncio.sleep(period)
                    writer.write(json.dumps(frame()).encode() + b"\n")
                    await writer.drain()
            except (ConnectionError, OSError):
                pass
            self.connected.discard(device_id)
            writer.close()

    async def _lidar(self) -> None:
        await self._stream(
            "lidar",
            "sim-lidar",
            self.settings.lidar_rate_hz,
            self._scan,
            lambda: self.lidar_plugged,
        )

    def _scan(self) -> dict[str, object]:
        s, slam = self.settings, self.config.slam
        b = self.body
        c, si = math.cos(b.yaw_rad), math.sin(b.yaw_rad)
        x = b.x_m + c * slam.laser_x_m - si * slam.laser_y_m
        y = b.y_m + si * slam.laser_x_m + c * slam.laser_y_m
        increment = 2.0 * math.pi / s.lidar_beams
        local = -math.pi + increment * np.arange(s.lidar_beams)
        angles = (local + b.yaw_rad + slam.laser_yaw_rad).astype(np.float64)
        now = self.now()
        w = self.world
        ranges = cast_rays(
            w.grid,
            w.origin_x_m,
            w.origin_y_m,
            w.resolution_m,
            x,
            y,
            angles,
            s.lidar_max_range_m,
            self.discs(),
        )
        ranges = ranges + self._rng.normal(0.0, s.lidar_noise_m, ranges.size)
        return {
            "type": "scan",
            "stamp": now,
            "angle_min": -math.pi,
            "angle_increment": increment,
            "range_min": 0.05,
            "range_max": s.lidar_max_range_m,
            "ranges": [round(float(r), 4) if math.isfinite(r) else None for r in ranges],
        }

    async def _gps(self) -> None:
        from navd.estimation.geo import GeoFrame  # noqa: PLC0415 - only with a datum

        world = self.config.world
        assert world.datum_latitude_deg is not None and world.datum_longitude_deg is not None
        geo = GeoFrame(
            world.datum_latitude_deg,
            world.datum_longitude_deg,
            map_rotation_rad=world.map_rotation_rad,
            zone=world.utm_zone,
            max_distance_m=world.utm_threshold_m,
        )
        sigma = self.settings.gps_noise_m

        def fix() -> dict[str, object]:
            dx, dy = self._rng.normal(0.0, sigma, 2)
            lat, lon = geo.to_wgs84(self.body.x_m + dx, self.body.y_m + dy)
            return {
                "type": "fix",
                "stamp": self.now(),
                "latitude": lat,
                "longitude": lon,
                "altitude": 0.0,
                "horizontal_accuracy": sigma,
            }

        await self._stream(
            "gps", "sim-gps", self.settings.gps_rate_hz, fix, lambda: self.gps_plugged
        )

    async def _imu(self) -> None:
        await self._stream("imu", "sim-imu", self.settings.imu_rate_hz, self._imu_frame)

    def _imu_frame(self) -> dict[str, object]:
        s = self.settings
        noise = self._rng.normal(0.0, 1.0, 6)
        ax, ay = self._last_accel
        return {
            "type": "imu",
            "stamp": self.now(),
            "angular_velocity": [
                s.gyro_noise_radps * noise[0],
                s.gyro_noise_radps * noise[1],
                self.body.angular_radps + s.gyro_bias_radps + s.gyro_noise_radps * noise[2],
            ],
            "linear_acceleration": [
                ax + s.accel_noise_mps2 * noise[3],
                ay + s.accel_noise_mps2 * noise[4],
                GRAVITY_MPS2 + s.accel_noise_mps2 * noise[5],
            ],
        }


async def _drain(reader: asyncio.StreamReader) -> None:
    """Read and drop what the daemon sends a sensor (errors are counted by the daemon)."""
    with contextlib.suppress(ConnectionError, OSError):
        while await reader.readline():
            pass
