"""The STM32 chassis on a UART: one "%d %d" line of wheel commands per period.

The driver obeys only DriveCommand (the safety gate's output). At a fixed rate it writes the
latest command, or "0 0" when none came for ``safety.reaction_timeout_s``. What it writes
speeds up no faster than the robot's acceleration limits from what it wrote last (after a
stop or a reopened port, from zero), whatever it is told; slowing down is never delayed. It
writes "0 0" when it starts, when it stops, at once on a SafeStop, and first thing after
reopening a lost port; a command received before the loss is never replayed. A lost port
(USB unplugged, pty closed) is reported as DeviceLost and reopened with exponential backoff,
in real time on either clock.
Lines the STM32 sends back are logged or, if configured, parsed as measured wheel speeds into
WheelOdometry. On real time, a ``StallWatch`` process beside the daemon writes "0 0" when the
daemon's lines stop for the reaction timeout (its loop stalled, or it died).
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
from typing import Any

import serial

from navd.drivers.errors import SerialPortError
from navd.drivers.kinematics import (
    body_velocity,
    format_command,
    ramp,
    wheel_command,
    wheel_speeds,
)
from navd.drivers.serial_port import open_exclusive
from navd.drivers.settings import ChassisSettings
from navd.drivers.stall_watch import StallWatch
from navd.lifecycle import Module, ModuleContext, MonotonicClock, ticks
from navd.lifecycle.messages import (
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DriveCommand,
    SafeStop,
    WheelOdometry,
)

__all__ = ["ChassisDriver"]

MAX_FEEDBACK_LINE = 256
LINE_COUNT_ID = "chassis"  # the chassis's name in the line counters (and in WheelOdometry)


class ChassisDriver(Module):
    """The chassis module ("chassis")."""

    def __init__(self) -> None:
        super().__init__("chassis")
        self._port: Any = None
        self._latest: DriveCommand | None = None
        self._latest_rx_s = 0.0
        self._written = (0.0, 0.0)  # [m/s, rad/s] the body velocity written last
        self._timed_out = True
        self._lost_reason = ""
        self._rx = bytearray()
        self._reading = False
        self.writes_stalled = 0
        self._watch: StallWatch | None = None
        self._watch_stops = 0  # the watch's stop lines seen by the loop

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(ChassisSettings.from_config, self._settings_changed)
        ctx.subscribe(DriveCommand, self._on_drive)
        ctx.subscribe(SafeStop, self._on_safe_stop)

    async def on_activate(self) -> None:
        self.ctx.spawn(self._run(), name="serial")

    async def on_deactivate(self) -> None:
        if self._port is not None:
            with contextlib.suppress(SerialPortError):
                self._write(0, 0)
            self._close()

    def settings_in_use(self) -> tuple[object, ...]:
        return (self.settings.value,)

    def _settings_changed(self, old: ChassisSettings, new: ChassisSettings) -> None:
        # The feedback lines are read only when they are used.
        if self._port is not None:
            watched = (old.reaction_timeout_s, old.period_s, old.line_ending)
            if self._watch is not None and watched != (
                new.reaction_timeout_s,
                new.period_s,
                new.line_ending,
            ):
                self._watch.close()
                self._watch = self._new_watch(self._port.fileno(), new)
            if new.feedback == "off":
                self._stop_reading()
            else:
                self._start_reading()

    # --- bus ----------------------------------------------------------------------------

    def _on_drive(self, cmd: DriveCommand) -> None:
        self._latest = cmd
        self._latest_rx_s = cmd.stamp  # the request's time: a re-swept old command ages too
        if cmd.is_stop:
            self._written = (0.0, 0.0)
            if self._port is not None:
                self._write_safely(0, 0)  # stopping never waits for the next tick

    def _on_safe_stop(self, stop: SafeStop) -> None:
        self._latest = None
        self._written = (0.0, 0.0)
        if self._port is not None:
            self._write_safely(0, 0)

    # --- the serial loop ----------------------------------------------------------------

    async def _run(self) -> None:
        backoff = self.settings.value.reconnect_initial_s
        reported_down = False
        while True:
            try:
                await self._open()
            except SerialPortError as err:
                if not reported_down:
                    self.ctx.log.error(
                        "chassis_unavailable",
                        port=self.settings.value.port,
                        error=str(err),
                        retry_s=backoff,
                    )
                    self._publish_lost(str(err))
                    reported_down = True
                self._close()  # opened but its first write failed: let go of the port's lock
                # Real time, on either clock: a port comes back in the world, not in a
                # simulation whose time may stand still until the wheels answer.
                await asyncio.sleep(backoff)
                backoff = min(backoff * 2.0, self.settings.value.reconnect_max_s)
                continue
            backoff = self.settings.value.reconnect_initial_s
            reported_down = False
            try:
                await self._drive_loop()
            except SerialPortError as err:
                self.ctx.log.error("chassis_lost", port=self.settings.value.port, error=str(err))
                self._publish_lost(str(err))
            except Exception as err:  # the serial task's supervised boundary: never go silent
                # a dead loop would leave the STM32 executing its last command: report, stop
                # the wheels if the port still works, and start over
                self.ctx.bus.report_failure(self.name, {"task": "serial loop"}, err)
                with contextlib.suppress(Exception):
                    self._write(0, 0)
                self._publish_lost(f"driver error: {type(err).__name__}: {err}")
                await asyncio.sleep(backoff)
            self._close()
            reported_down = True

    async def _open(self) -> None:
        settings = self.settings.value
        try:
            port = await asyncio.to_thread(
                open_exclusive, settings.port, settings.baudrate, timeout=0, write_timeout=0
            )
        except (serial.SerialException, OSError, ValueError) as err:
            raise SerialPortError(f"cannot open {settings.port}: {err}") from err
        self._port = port
        if isinstance(self.ctx.clock, MonotonicClock):  # simulated time may stand still
            self._watch = self._new_watch(port.fileno(), settings)
        self._lost_reason = ""
        self._latest = None  # never replay a command from before the port was (re)opened
        self._written = (0.0, 0.0)
        self._rx.clear()
        self._write(0, 0)
        if self.settings.value.feedback != "off":
            self._start_reading()
        self.ctx.log.info("chassis_open", port=settings.port, baudrate=settings.baudrate)
        now = self.ctx.clock.now()
        self.ctx.publish(
            DeviceConnected(
                stamp=now, received=now, device_id=settings.port, kind=DeviceKind.CHASSIS
            )
        )

    async def _drive_loop(self) -> None:
        async for _ in ticks(self.ctx.clock, lambda: self.settings.value.period_s):
            if self._lost_reason:
                raise SerialPortError(self._lost_reason)
            if self._watch is not None and self._watch.stops != self._watch_stops:
                self._stalled(self._watch.stops)
            self._write(*self._command_now())

    @staticmethod
    def _new_watch(port_fd: int, settings: ChassisSettings) -> StallWatch:
        stop = format_command(0, 0, settings.line_ending)
        return StallWatch(port_fd, settings.reaction_timeout_s, settings.period_s, stop)

    def _stalled(self, stops: int) -> None:
        """The watch wrote stop lines: this loop was stalled past the reaction timeout. The
        wheels were stopped, so what is written next speeds up from zero."""
        self.ctx.log.warning(
            "chassis_stall_stopped",
            stop_lines=stops - self._watch_stops,
            effect="the event loop wrote no wheel line for safety.reaction_timeout_s; the stall "
            "watch stopped the wheels",
        )
        self._watch_stops = stops
        self._written = (0.0, 0.0)

    def _command_now(self) -> tuple[int, int]:
        cmd = self._latest
        now = self.ctx.clock.now()
        settings = self.settings.value
        timeout = settings.reaction_timeout_s
        if cmd is None or now - self._latest_rx_s > timeout:
            if not self._timed_out and cmd is not None:
                self.ctx.log.warning(
                    "reaction_timeout",
                    silent_s=round(now - self._latest_rx_s, 3),
                    timeout_s=timeout,
                )
            self._timed_out = True
            self._written = (0.0, 0.0)
            return 0, 0
        self._timed_out = False
        period = settings.period_s
        linear = ramp(self._written[0], cmd.linear_mps, settings.max_linear_accel_mps2 * period)
        angular = ramp(
            self._written[1], cmd.angular_radps, settings.max_angular_accel_radps2 * period
        )
        self._written = (linear, angular)
        left, right = wheel_speeds(linear, angular, settings.track_width_m)
        return wheel_command(left, right, settings.calibration)

    # --- port I/O -----------------------------------------------------------------------

    def _write(self, left: int, right: int) -> None:
        line = format_command(left, right, self.settings.value.line_ending)
        try:
            self._port.write(line)
            if self._watch is not None:
                self._watch.beat()
            self.ctx.line_counts.add_sent(LINE_COUNT_ID)
        except serial.SerialTimeoutException:
            self.writes_stalled += 1  # nobody reads the UART: drop this line, not the port
            if self.writes_stalled == 1 or self.writes_stalled % 100 == 0:
                self.ctx.log.warning(
                    "chassis_write_stalled",
                    port=self.settings.value.port,
                    stalled_lines=self.writes_stalled,
                )
        except (serial.SerialException, OSError) as err:
            self._lost_reason = f"write failed: {err}"
            raise SerialPortError(self._lost_reason) from err

    def _write_safely(self, left: int, right: int) -> None:
        """A write from a bus handler: a failure is left to the serial loop to handle."""
        with contextlib.suppress(SerialPortError):
            self._write(left, right)

    def _readable(self) -> None:
        try:
            data = self._port.read(4096)
        except (serial.SerialException, OSError) as err:
            self._lost_reason = f"read failed: {err}"
            self._stop_reading()
            return
        self._rx += data
        while (end := self._rx.find(b"\n")) >= 0:
            line = bytes(self._rx[:end]).strip()
            del self._rx[: end + 1]
            if line:
                self.ctx.line_counts.take(LINE_COUNT_ID, 1, functools.partial(self._feedback, line))
        if len(self._rx) > MAX_FEEDBACK_LINE:
            self.ctx.log.warning("chassis_feedback_garbled", bytes=len(self._rx))
            self._rx.clear()

    def _feedback(self, line: bytes) -> None:
        settings = self.settings.value
        if settings.feedback == "off":
            return  # switched off while the line was waiting its turn
        if settings.feedback == "log":
            self.ctx.log.info("chassis_feedback", line=line.decode(errors="replace"))
            return
        try:
            left_units, right_units = (int(v) for v in line.split())
        except ValueError:
            self.ctx.log.warning(
                "chassis_feedback_unparsed",
                line=line.decode(errors="replace"),
                expected="two integers '%d %d'",
            )
            return
        cal = settings.calibration
        left = (-left_units if cal.invert_left else left_units) / cal.scale_per_mps
        right = (-right_units if cal.invert_right else right_units) / cal.scale_per_mps
        linear, angular = body_velocity(left, right, settings.track_width_m)
        now = self.ctx.clock.now()
        self.ctx.publish(
            WheelOdometry(
                stamp=now,
                received=now,
                device_id=LINE_COUNT_ID,
                linear_mps=linear,
                angular_radps=angular,
            )
        )

    def _start_reading(self) -> None:
        if self._port is not None and not self._reading:
            asyncio.get_running_loop().add_reader(self._port.fileno(), self._readable)
            self._reading = True

    def _stop_reading(self) -> None:
        if self._port is not None and self._reading:
            self._reading = False
            with contextlib.suppress(ValueError, OSError, RuntimeError):
                asyncio.get_running_loop().remove_reader(self._port.fileno())

    def _close(self) -> None:
        if self._watch is not None:
            self._watch.close()  # it holds the port (and its lock) open with it
            self._watch, self._watch_stops = None, 0
        if self._port is None:
            return
        self._stop_reading()
        with contextlib.suppress(serial.SerialException, OSError):
            self._port.close()
        self._port = None

    def _publish_lost(self, reason: str) -> None:
        now = self.ctx.clock.now()
        self.ctx.publish(
            DeviceLost(
                stamp=now,
                received=now,
                device_id=self.settings.value.port,
                kind=DeviceKind.CHASSIS,
                reason=reason,
            )
        )
