"""The simulator on simulated time: it owns the daemon's clock, one round per physics step.

A round at time t: move the daemon to t (naming every line sent so far, so it has read them);
read the wheel lines it says it wrote; plug or unplug sensors; send the frames due at t,
stamped t; write the encoder line if due; step the world to t + dt. The same seed gives the
same drive, whatever the machine's speed.
"""

from __future__ import annotations

import asyncio
import time
from collections import Counter

from navd.sim.errors import SimError
from navd.sim.links import RECONNECT_S, PtyChassis, SensorLinks
from navd.sim.physics import SimRobot
from navd.sim.sensors import SensorModels, SimSensor
from navd.wire import (
    AsyncClient,
    ClientError,
    ClockAck,
    ClockFrame,
    ConnectionClosedError,
    ErrorFrame,
    RequestRefusedError,
)

__all__ = ["Lockstep"]

ACK_TIMEOUT_S = 60.0  # [s] real time a lockstep step may take the daemon
STEP_TOLERANCE_S = 1e-9  # [s] a step time k * dt that rounds past ``until_s`` still counts
FIRST_ACK_TIMEOUT_S = 600.0  # [s] the same for the first step: it waits for kernels to compile
CLOCK_LINK_TIMEOUT_S = 180.0  # [s] for the daemon to take the clock (the session waits 120 s)
CHASSIS_READ_TIMEOUT_S = 5.0  # [s] real time for wheel lines the daemon says it wrote


class Lockstep:
    """The simulator's time when it drives the daemon's clock.

    Args:
        robot, models, chassis, links: the simulator's robot, sensors and links.
        feedback_rate_hz: [Hz] encoder lines per second (0: none).
    """

    def __init__(
        self,
        robot: SimRobot,
        models: SensorModels,
        chassis: PtyChassis,
        links: SensorLinks,
        feedback_rate_hz: float,
    ) -> None:
        self.robot = robot
        self.models = models
        self.chassis = chassis
        self.links = links
        self.settings = models.settings
        self.feedback_rate_hz = feedback_rate_hz
        self.time_s = 0.0  # [s] simulated time
        self.steps = 0
        self.released = asyncio.Event()  # time stands at 0 until a scenario lets it go
        self._writers: dict[str, AsyncClient] = {}
        self._sent: Counter[str] = Counter()

    async def run(self, stop: asyncio.Event, until_s: float | None = None) -> None:
        """Drive the daemon's clock and the world together until ``stop`` is set or, with
        ``until_s``, until the step at that simulated time [s] is done (the same last step
        every run, however fast the machine).

        Raises:
            SimError: the daemon refused the clock, closed it, or did not answer a step.
        """
        s = self.settings
        dt = 1.0 / s.physics_rate_hz
        sensors = self.models.sensors()
        feedback_every = _steps_per_sample(s.physics_rate_hz, self.feedback_rate_hz)
        clock = await self._clock_link(stop)
        if clock is None:
            return  # stopped before the daemon answered: whoever stopped us says why
        await self.released.wait()
        try:
            while not stop.is_set():
                t = self.steps * dt
                if until_s is not None and t > until_s + STEP_TOLERANCE_S:
                    return
                clock.send(ClockFrame(time=t, frames=dict(self._sent)))
                try:
                    ack = await _clock_ack(
                        clock, t, FIRST_ACK_TIMEOUT_S if self.steps == 0 else ACK_TIMEOUT_S
                    )
                except SimError:
                    if stop.is_set():
                        return  # the daemon went first; nothing to report
                    raise
                self.time_s = t
                await self._read_chassis(ack.sent.get("chassis", 0))
                for sensor in sensors:
                    await self._step_sensor(sensor)
                # The STM32 speaks once navd has spoken to it: lines written before navd
                # opened its end would be flushed by the open, and never counted by navd.
                heard = self.robot.wheels.lines > 0
                if heard and feedback_every and self.steps % feedback_every == 0:
                    self.chassis.write(self.robot.encoder_line())
                    self._sent["chassis"] += 1
                self.robot.step(t, dt)
                self.steps += 1
        finally:
            clock.writer.close()
            for client in self._writers.values():
                client.writer.close()

    async def _clock_link(self, stop: asyncio.Event) -> AsyncClient | None:
        """The clock connection, tried again while the daemon starts (None if ``stop`` is
        set first: the session gave up on the daemon and says why)."""
        deadline = time.monotonic() + CLOCK_LINK_TIMEOUT_S
        while not stop.is_set():
            try:
                return await self.links.open("clock", "sim-clock")
            except RequestRefusedError as err:
                raise SimError(str(err)) from err  # refused: the daemon runs on real time
            except (ClientError, OSError) as err:
                if time.monotonic() > deadline:
                    raise SimError(
                        f"navd did not answer on port {self.settings.port} within "
                        f"{CLOCK_LINK_TIMEOUT_S} s (last: {err})"
                    ) from err
                await asyncio.sleep(RECONNECT_S)
        return None

    async def _step_sensor(self, sensor: SimSensor) -> None:
        plugged = sensor.is_plugged()
        client = self._writers.get(sensor.device_id)
        if client is not None and not plugged:
            client.writer.close()  # the daemon counts the end of a connection as a line
            del self._writers[sensor.device_id]
            self._sent[sensor.device_id] += 1
            self.links.closed(sensor.device_id)
            client = None
        elif client is None and plugged:
            client = self._writers[sensor.device_id] = await self.links.open_sensor(
                sensor.role, sensor.device_id
            )
        every = _steps_per_sample(self.settings.physics_rate_hz, sensor.rate_hz)
        if client is not None and self.steps % every == 0 and not sensor.is_silent():
            frame = sensor.frame(self.time_s)
            if frame is not None:  # a beacon sensor with none in range says nothing
                client.send(frame)
            sensor.last_sent_s = self.time_s
            self._sent[sensor.device_id] += 1
            await client.drain()

    async def _read_chassis(self, lines: int) -> None:
        """Read the pseudo-terminal until ``lines`` wheel lines came in all (the daemon wrote
        them before it answered; the kernel may still be passing them on)."""
        deadline = time.monotonic() + CHASSIS_READ_TIMEOUT_S
        wheels = self.robot.wheels
        while True:
            self.robot.take_wheel_bytes(self.chassis.read(), self.time_s)
            if wheels.lines + wheels.bad_lines >= lines:
                return
            if time.monotonic() > deadline:
                raise SimError(
                    f"navd says it wrote {lines} wheel lines; {wheels.lines} arrived "
                    f"within {CHASSIS_READ_TIMEOUT_S} s"
                )
            await asyncio.sleep(0.0005)


def _steps_per_sample(physics_hz: float, rate_hz: float) -> int:
    """Physics steps between samples of a ``rate_hz`` stream (0 for none)."""
    return max(1, round(physics_hz / rate_hz)) if rate_hz > 0 else 0


async def _clock_ack(clock: AsyncClient, time_s: float, timeout_s: float) -> ClockAck:
    """The daemon's answer to the clock frame for ``time_s``, within ``timeout_s`` [s].

    Raises:
        SimError: the daemon closed, refused the frame, or did not answer in time.
    """
    try:
        answer = await clock.receive(timeout_s)
    except TimeoutError as err:
        raise SimError(f"navd did not finish the step to {time_s} s within {timeout_s} s") from err
    except ConnectionClosedError as err:
        raise SimError(f"navd closed the clock connection at {time_s} s") from err
    if isinstance(answer, ErrorFrame):
        raise SimError(f"navd refused the clock frame for {time_s} s: {answer.describe()}")
    if not isinstance(answer, ClockAck):
        raise SimError(f"navd answered the clock frame for {time_s} s with {answer.type!r}")
    return answer
