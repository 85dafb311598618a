"""The simulator: it plays the robot through the same interfaces as the hardware.

The chassis is a pseudo-terminal (``links.PtyChassis``); the lidar, IMU, GNSS receiver and
compass are TCP clients of the daemon, exactly like external sensor programs, reconnecting if
the daemon is not up yet; the truth (the body's pose) is recorded for scoring. The robot and
its sensors are pure (``physics``, ``sensors``); this module runs them on a clock.

Two clocks (``SimSettings.clock``): "real", where the world runs at ``physics_rate_hz`` in
real time, or "lockstep", where the simulator owns the time (``lockstep.Lockstep``):
it connects as the daemon's clock client and each physics step is one round, deterministic
for a seed and as fast as the two processes allow. The daemon must then run with
``lifecycle.clock = "simulated"``.
"""

from __future__ import annotations

import asyncio
import contextlib
import time

from navd.config import NavdConfig
from navd.geometry import Pose2
from navd.sim.body import Body
from navd.sim.links import RECONNECT_S, PtyChassis, SensorLinks
from navd.sim.lockstep import Lockstep
from navd.sim.physics import SimRobot
from navd.sim.sensors import SensorModels, SimSensor
from navd.sim.settings import SimSettings
from navd.sim.world import World
from navd.wire import AsyncClient

__all__ = ["Simulator"]

MAX_STEP_S = 0.1  # [s] a real-time step longer than this (a stalled process) is cut short


class Simulator:
    """One simulated robot in ``world``, set up by ``config`` (robot, chassis, lidar mount).

    Args:
        world: what the robot lives in.
        config: the daemon's config (footprint, calibration, lidar mount, limits, datum).
        settings: connections and sensors.
        start: where the robot starts (default: the world's start).
    """

    def __init__(
        self,
        world: World,
        config: NavdConfig,
        settings: SimSettings,
        start: Pose2 | None = None,
    ) -> None:
        self.world = world
        self.config = config
        self.settings = settings
        self.robot = SimRobot(world, config, start)
        self.sensors = SensorModels(self.robot, config, settings)
        self.chassis = PtyChassis(settings.tty_link)
        self.links = SensorLinks(settings)
        self.started = time.monotonic()
        self.lockstep = (
            Lockstep(self.robot, self.sensors, self.chassis, self.links, self.feedback_rate_hz())
            if settings.clock == "lockstep"
            else None
        )

    @property
    def body(self) -> Body:
        """The robot's true body (pose, velocity, collisions, clearance)."""
        return self.robot.body

    @property
    def truth(self) -> list[tuple[float, float, float, float]]:
        """(t [s], x [m], y [m], yaw [rad]) of the body every 0.1 s."""
        return self.robot.truth

    @property
    def chassis_lines(self) -> int:
        """How many "%d %d" wheel command lines the chassis side received."""
        return self.robot.wheels.lines

    @property
    def connected(self) -> set[str]:
        """Device ids of the sensor connections open now."""
        return self.links.connected

    def now(self) -> float:
        """[s] simulation time: the lockstep clock, or seconds since the simulator started."""
        if self.lockstep is not None:
            return self.lockstep.time_s
        return time.monotonic() - self.started

    def release_clock(self) -> None:
        """Let a lockstep simulation start moving time (it waits for this, so a scenario can
        send its goal at time 0; on real time there is nothing to hold)."""
        if self.lockstep is not None:
            self.lockstep.released.set()

    def feedback_rate_hz(self) -> float:
        """Encoder lines per second; none when the daemon does not read them."""
        return 0.0 if self.config.chassis.feedback == "off" else self.settings.feedback_rate_hz

    async def run(self, stop: asyncio.Event, until_s: float | None = None) -> None:
        """Play the robot until ``stop`` is set or, on the lockstep clock, ``until_s`` [s] of
        simulated time have run (on real time the caller watches the time and sets ``stop``)."""
        self.chassis.open()
        try:
            if self.lockstep is not None:
                await self.lockstep.run(stop, until_s)
            else:
                await self._run_real_time(stop)
        finally:
            self.chassis.close()

    async def _run_real_time(self, stop: asyncio.Event) -> None:
        loop = asyncio.get_running_loop()
        loop.add_reader(self.chassis.fd, self._chassis_readable)
        tasks = [loop.create_task(self._physics(), name="sim-physics")]
        tasks += [
            loop.create_task(self._stream(sensor), name=sensor.device_id)
            for sensor in self.sensors.sensors()
        ]
        if self.feedback_rate_hz() > 0:
            tasks.append(loop.create_task(self._feedback(), name="sim-feedback"))
        try:
            await stop.wait()
        finally:
            for task in tasks:
                task.cancel()
            for task in tasks:
                with contextlib.suppress(asyncio.CancelledError):
                    await task
            loop.remove_reader(self.chassis.fd)

    def _chassis_readable(self) -> None:
        self.robot.take_wheel_bytes(self.chassis.read(), self.now())

    async def _physics(self) -> None:
        period = 1.0 / self.settings.physics_rate_hz
        last = self.now()
        while True:
            await asyncio.sleep(period)
            now = self.now()
            self.robot.step(now, min(now - last, MAX_STEP_S))
            last = now

    async def _feedback(self) -> None:
        period = 1.0 / self.feedback_rate_hz()
        while True:
            await asyncio.sleep(period)
            self.chassis.write(self.robot.encoder_line())

    async def _stream(self, sensor: SimSensor) -> None:
        """Send the sensor's frames at its rate on a (re)connected connection, while it is
        plugged in."""
        period = 1.0 / sensor.rate_hz
        while True:
            while not sensor.is_plugged():
                await asyncio.sleep(period)
            client: AsyncClient = await self.links.keep_trying(
                sensor.role, sensor.device_id, RECONNECT_S
            )
            try:
                while sensor.is_plugged():
                    await asyncio.sleep(period)
                    if sensor.is_silent():
                        continue
                    now = self.now()
                    frame = sensor.frame(now)
                    if frame is not None:  # a beacon sensor with none in range says nothing
                        client.send(frame)
                    sensor.last_sent_s = now
                    await client.drain()
            except (ConnectionError, OSError):
                pass
            self.links.closed(sensor.device_id)
            client.writer.close()
