"""The simulator process: it plays the robot through the same interfaces as the hardware.

- The chassis: a pseudo-terminal whose far end is linked at ``tty_link``; the daemon's
  chassis driver opens that path as it would /dev/ttyS0. "%d %d" lines become a commanded body
  velocity through the robot's calibration; like the firmware should, the motors stop when no
  line comes for ``COMMAND_TIMEOUT_S``; measured wheel speeds go back as "%d %d" encoder lines.
- The sensors: TCP clients of the daemon, exactly like external sensor programs: a 2D lidar
  (ray cast against the world, Gaussian range noise), an IMU (gyro with bias and noise,
  accelerations of the true motion plus gravity), a GNSS receiver (when the daemon has a
  datum) and a magnetic compass (through the daemon's declination and grid convergence).
  They reconnect if the daemon is not up yet.
- The truth: the body's pose is recorded for scoring.

Two clocks (``SimSettings.clock``): "real", where the world runs at ``physics_rate_hz`` in
real time, or "lockstep", where the simulator owns the time: it connects as the daemon's
clock client and each physics step is one round (move the daemon's clock, read the wheel
commands it wrote, send the sensor frames due, step the world), deterministic for a seed and
as fast as the two processes allow. The daemon must run with ``lifecycle.clock =
"simulated"``.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import time
import tty
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

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
ACK_TIMEOUT_S = 60.0  # [s] real time a lockstep step may take the daemon
FIRST_ACK_TIMEOUT_S = 600.0  # [s] the same for the first step: it waits for kernels to compile
CHASSIS_READ_TIMEOUT_S = 5.0  # [s] real time for wheel lines the daemon says it wrote


@dataclass(frozen=True, slots=True)
class SimSettings:
    """How the simulator connects and what its sensors are like.

    Attributes:
        host, port: the daemon's TCP server; token: its ``tcp.token`` when it has one.
        tty_link: path of the symlink to the chassis end of the pseudo-terminal.
        lidar_beams, lidar_rate_hz, lidar_noise_m, lidar_max_range_m: the 2D lidar.
        imu_rate_hz, gyro_noise_radps, gyro_bias_radps, accel_noise_mps2: the IMU (0 Hz: none).
        gps_rate_hz, gps_noise_m: a GNSS receiver, streaming only when the daemon's config
            has a datum (``world.datum_latitude_deg``/``longitude_deg``, at map (0, 0)).
        compass_rate_hz, compass_noise_deg: a magnetic compass (0 Hz: none); it reports
            magnetic bearings, so the daemon's ``world.magnetic_declination_deg`` applies.
        physics_rate_hz: world steps per second (in lockstep: clock steps per second; sensor
            rates are rounded to whole steps).
        feedback_rate_hz: encoder lines per second (0: none).
        seed: seeds every noise source.
        clock: "real" or "lockstep" (the simulator drives the daemon's simulated clock).
    """

    host: str = "127.0.0.1"
    port: int = 7420
    token: str | None = None
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
    compass_rate_hz: float = 10.0
    compass_noise_deg: float = 2.0
    physics_rate_hz: float = 100.0
    feedback_rate_hz: float = 20.0
    seed: int = 0
    clock: Literal["real", "lockstep"] = "real"


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
        self.lockstep = settings.clock == "lockstep"
        self.time_s = 0.0  # [s] simulated time in lockstep
        self.steps = 0
        self._released = asyncio.Event()
        self._geo: Any = None
        self._geo_ready = False

    @property
    def chassis_lines(self) -> int:
        """How many "%d %d" wheel command lines the chassis side received."""
        return self._drive.lines

    def now(self) -> float:
        """[s] simulation time: the lockstep clock, or seconds since the simulator started."""
        if self.lockstep:
            return self.time_s
        return time.monotonic() - self.started

    def release_clock(self) -> None:
        """Let a lockstep simulation start moving time (it waits for this, so a scenario can
        send its goal at time 0)."""
        self._released.set()

    async def run(self, stop: asyncio.Event) -> None:
        """Play the robot until ``stop`` is set."""
        self._open_pty()
        if self.lockstep:
            try:
                await self._run_lockstep(stop)
            finally:
                self._close_pty()
            return
        loop = asyncio.get_running_loop()
        loop.add_reader(self._master, self._readable)
        tasks = [asyncio.create_task(self._physics(), name="sim-physics")]
        tasks += [
            asyncio.create_task(self._stream(sensor), name=sensor.device_id)
            for sensor in self._sensors()
        ]
        if self._feedback_rate_hz() > 0:
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
        self._take(data)

    def _take(self, data: bytes) -> None:
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

    def _feedback_rate_hz(self) -> float:
        """Encoder lines per second; none when the daemon does not read them."""
        return 0.0 if self.config.chassis.feedback == "off" else self.settings.feedback_rate_hz

    async def _feedback(self) -> None:
        period = 1.0 / self._feedback_rate_hz()
        while True:
            await asyncio.sleep(period)
            with contextlib.suppress(BlockingIOError, OSError):
                self._write_encoders()

    def _write_encoders(self) -> None:
        cal = WheelCalibration.from_config(self.config.chassis)
        left, right = encode_wheels(*self.body.wheels(self.config.robot.track_width_m), cal)
        os.write(self._master, b"%d %d\n" % (left, right))

    # --- world -----------------------------------------------------------------------------

    async def _physics(self) -> None:
        period = 1.0 / self.settings.physics_rate_hz
        last = self.now()
        while True:
            await asyncio.sleep(period)
            now = self.now()
            self._step_world(now, min(now - last, 0.1))
            last = now

    def _step_world(self, now: float, dt: float) -> None:
        """Move the movers and the body over ``dt`` [s] at time ``now`` [s]."""
        command = self._drive.command
        if now - self._drive.commanded_at > COMMAND_TIMEOUT_S:
            command = (0.0, 0.0)  # the firmware's own watchdog
        v0, w0 = self.body.linear_mps, self.body.angular_radps
        self.advance_movers(dt)
        self.body.step(dt, command, self.config, self.world, self.discs())
        if dt > 0:
            self._last_accel = ((self.body.linear_mps - v0) / dt, v0 * w0)
        if not self.truth or now >= self.truth[-1][0] + 0.1 - 1e-9:
            self.truth.append((now, self.body.x_m, self.body.y_m, self.body.yaw_rad))

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

    async def _open_link(
        self, role: str, device_id: str
    ) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
        """One connection to the daemon with a completed hello.

        Raises:
            OSError, TimeoutError, ValueError: the daemon is not there or did not welcome us.
        """
        reader, writer = await asyncio.open_connection(self.settings.host, self.settings.port)
        hello = {
            "type": "hello",
            "protocol": PROTOCOL_VERSION,
            "role": role,
            "device_id": device_id,
        }
        if self.settings.token is not None:
            hello["token"] = self.settings.token
        writer.write(json.dumps(hello).encode() + b"\n")
        answer = json.loads(await asyncio.wait_for(reader.readline(), 5.0))
        if answer.get("type") != "welcome":
            writer.close()
            raise ValueError(f"navd refused the {role} client {device_id!r}: {answer}")
        self.connected.add(device_id)
        return reader, writer

    async def _connect(self, role: str, device_id: str) -> asyncio.StreamWriter:
        """A sensor connection after a welcome; retries until the daemon answers."""
        while True:
            try:
                reader, writer = await self._open_link(role, device_id)
            except (OSError, TimeoutError, ValueError):
                await asyncio.sleep(RECONNECT_S)
                continue
            task = asyncio.get_running_loop().create_task(_drain(reader))
            self._readers.add(task)
            task.add_done_callback(self._readers.discard)
            return writer

    async def _stream(self, sensor: _Sensor) -> None:
        """Send the sensor's frames at its rate on a (re)connected connection, while it is
        plugged in (real time)."""
        period = 1.0 / sensor.rate_hz
        while True:
            while not sensor.is_plugged():
                await asyncio.sleep(period)
            writer = await self._connect(sensor.role, sensor.device_id)
            try:
                while sensor.is_plugged():
                    await asyncio.sleep(period)
                    writer.write(json.dumps(sensor.frame()).encode() + b"\n")
                    await writer.drain()
            except (ConnectionError, OSError):
                pass
            self.connected.discard(sensor.device_id)
            writer.close()

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

    def _has_gps(self) -> bool:
        return self.settings.gps_rate_hz > 0 and self.config.world.datum_latitude_deg is not None

    def _geo_frame(self) -> Any:
        """The daemon's GeoFrame from its datum, or None without one."""
        if not self._geo_ready:
            self._geo_ready = True
            world = self.config.world
            if world.datum_latitude_deg is not None and world.datum_longitude_deg is not None:
                from navd.estimation.geo import GeoFrame  # noqa: PLC0415 - only with a datum

                self._geo = GeoFrame(
                    world.datum_latitude_deg,
                    world.datum_longitude_deg,
                    map_rotation_rad=world.map_rotation_rad,
                    zone=world.utm_zone,
                    max_distance_m=world.utm_threshold_m,
                )
        return self._geo

    def _fix_frame(self) -> dict[str, object]:
        sigma = self.settings.gps_noise_m
        dx, dy = self._rng.normal(0.0, sigma, 2)
        lat, lon = self._geo_frame().to_wgs84(self.body.x_m + dx, self.body.y_m + dy)
        return {
            "type": "fix",
            "stamp": self.now(),
            "latitude": lat,
            "longitude": lon,
            "altitude": 0.0,
            "horizontal_accuracy": sigma,
        }

    def heading_frame(self) -> dict[str, object]:
        """A magnetic bearing of the true yaw: the inverse of the daemon's conversion."""
        world = self.config.world
        geo = self._geo_frame()
        convergence = geo.grid_convergence_rad if geo is not None else 0.0
        enu_yaw = self.body.yaw_rad + world.map_rotation_rad + convergence
        true_bearing = 90.0 - math.degrees(enu_yaw)
        noise = self._rng.normal(0.0, self.settings.compass_noise_deg)
        magnetic = (true_bearing - world.magnetic_declination_deg + noise) % 360.0
        return {
            "type": "heading",
            "stamp": self.now(),
            "bearing_deg": magnetic if magnetic < 360.0 else 0.0,
            "accuracy_deg": self.settings.compass_noise_deg,
        }

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

    def _sensors(self) -> list[_Sensor]:
        """The sensors this robot has, in both clocks."""
        s = self.settings
        sensors = [
            _Sensor("lidar", "sim-lidar", s.lidar_rate_hz, self._scan, lambda: self.lidar_plugged)
        ]
        if s.imu_rate_hz > 0:
            sensors.append(_Sensor("imu", "sim-imu", s.imu_rate_hz, self._imu_frame))
        if self._has_gps():
            sensors.append(
                _Sensor("gps", "sim-gps", s.gps_rate_hz, self._fix_frame, lambda: self.gps_plugged)
            )
        if s.compass_rate_hz > 0:
            sensors.append(_Sensor("compass", "sim-compass", s.compass_rate_hz, self.heading_frame))
        return sensors

    # --- lockstep ---------------------------------------------------------------------------

    async def _run_lockstep(self, stop: asyncio.Event) -> None:
        """Own the daemon's clock: one round per physics step until ``stop`` is set.

        A round at time t: move the daemon to t (naming every line sent so far, so it has
        read them); read the wheel lines it says it wrote; plug or unplug sensors; send the
        frames due at t, stamped t; write the encoder line if due; step the world to t + dt.
        """
        s = self.settings
        dt = 1.0 / s.physics_rate_hz
        sensors = self._sensors()
        feedback_every = _steps_per_sample(s.physics_rate_hz, self._feedback_rate_hz())
        sent: Counter[str] = Counter()
        reader, writer = await self._clock_link()
        await self._released.wait()
        try:
            while not stop.is_set():
                t = self.steps * dt
                writer.write(
                    json.dumps({"type": "clock", "time": t, "frames": dict(sent)}).encode() + b"\n"
                )
                try:
                    ack = await _clock_ack(
                        reader, t, FIRST_ACK_TIMEOUT_S if self.steps == 0 else ACK_TIMEOUT_S
                    )
                except SimError:
                    if stop.is_set():
                        return  # the daemon went first; nothing to report
                    raise
                self.time_s = t
                await self._read_chassis(int(ack.get("sent", {}).get("chassis", 0)))
                for sensor in sensors:
                    await self._lockstep_sensor(sensor, sent)
                if feedback_every and self.steps % feedback_every == 0:
                    self._write_encoders()
                    sent["chassis"] += 1
                self._step_world(t, dt)
                self.steps += 1
        finally:
            writer.close()
            for sensor in sensors:
                if sensor.writer is not None:
                    sensor.writer.close()

    async def _clock_link(self) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
        deadline = time.monotonic() + ACK_TIMEOUT_S
        while True:
            try:
                return await self._open_link("clock", "sim-clock")
            except ValueError as err:
                raise SimError(str(err)) from err  # refused: the daemon runs on real time
            except (OSError, TimeoutError) as err:
                if time.monotonic() > deadline:
                    raise SimError(
                        f"navd did not answer on port {self.settings.port} within {ACK_TIMEOUT_S} s"
                    ) from err
                await asyncio.sleep(RECONNECT_S)

    async def _lockstep_sensor(self, sensor: _Sensor, sent: Counter[str]) -> None:
        plugged = sensor.is_plugged()
        if sensor.writer is not None and not plugged:
            sensor.writer.close()  # the daemon counts the end of a connection as a line
            sensor.writer = None
            sent[sensor.device_id] += 1
            self.connected.discard(sensor.device_id)
        elif sensor.writer is None and plugged:
            reader, sensor.writer = await self._open_link(sensor.role, sensor.device_id)
            task = asyncio.get_running_loop().create_task(_drain(reader))
            self._readers.add(task)
            task.add_done_callback(self._readers.discard)
        every = _steps_per_sample(self.settings.physics_rate_hz, sensor.rate_hz)
        if sensor.writer is not None and self.steps % every == 0:
            sensor.writer.write(json.dumps(sensor.frame()).encode() + b"\n")
            sent[sensor.device_id] += 1
            await sensor.writer.drain()

    async def _read_chassis(self, lines: int) -> None:
        """Read the pseudo-terminal until ``lines`` wheel lines came in all (the daemon wrote
        them before it answered; the kernel may still be passing them on)."""
        deadline = time.monotonic() + CHASSIS_READ_TIMEOUT_S
        while True:
            try:
                while data := os.read(self._master, 4096):
                    self._take(data)
            except (BlockingIOError, OSError):
                pass
            if self._drive.lines + self._drive.bad_lines >= lines:
                return
            if time.monotonic() > deadline:
                raise SimError(
                    f"navd says it wrote {lines} wheel lines; {self._drive.lines} arrived "
                    f"within {CHASSIS_READ_TIMEOUT_S} s"
                )
            await asyncio.sleep(0.0005)


@dataclass
class _Sensor:
    """One simulated sensor: its connection, rate, frames and (in lockstep) its writer."""

    role: str
    device_id: str
    rate_hz: float
    frame: Callable[[], dict[str, object]]
    plugged: Callable[[], bool] | None = None
    writer: asyncio.StreamWriter | None = None

    def is_plugged(self) -> bool:
        """False while a scenario has it unplugged."""
        return self.plugged is None or self.plugged()


def _steps_per_sample(physics_hz: float, rate_hz: float) -> int:
    """Physics steps between samples of a ``rate_hz`` stream (0 for none)."""
    return max(1, round(physics_hz / rate_hz)) if rate_hz > 0 else 0


async def _clock_ack(
    reader: asyncio.StreamReader, time_s: float, timeout_s: float
) -> dict[str, Any]:
    """The daemon's answer to the clock frame for ``time_s``, within ``timeout_s`` [s].

    Raises:
        SimError: the daemon closed, refused the frame, or did not answer in time.
    """
    try:
        line = await asyncio.wait_for(reader.readline(), timeout_s)
    except TimeoutError as err:
        raise SimError(f"navd did not finish the step to {time_s} s within {timeout_s} s") from err
    if not line:
        raise SimError(f"navd closed the clock connection at {time_s} s")
    answer: dict[str, Any] = json.loads(line)
    if answer.get("type") != "clock_ack":
        raise SimError(f"navd answered the clock frame for {time_s} s with {answer}")
    return answer


async def _drain(reader: asyncio.StreamReader) -> None:
    """Read and drop what the daemon sends a sensor (errors are counted by the daemon)."""
    with contextlib.suppress(ConnectionError, OSError):
        while await reader.readline():
            pass
