"""A simulation session: the real daemon process, the simulator, and a control client.

``async with session(world, work_dir) as s:`` writes a daemon config (chassis on the
simulator's pseudo-terminal with encoder feedback, the TCP server on a free port, maps in
``work_dir/maps``, plus any overrides), starts the simulator, then ``python -m navd run``
(its log in ``work_dir/navd.log`` unless another path is given), and connects a control
client: tried again while the daemon starts, given up with the end of its log if the daemon
exits, and started again on another port if another program took the free one first. On exit
the daemon gets SIGTERM (SIGKILL after 15 s) and the simulator stops. The demo and the
end-to-end scenarios are built on it.
"""

from __future__ import annotations

import asyncio
import contextlib
import signal
import sys
import time
from collections.abc import AsyncIterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tomli_w

from navd.config import NavdConfig
from navd.geometry import Pose2
from navd.sim.errors import SimError
from navd.sim.ports import free_port
from navd.sim.runner import Simulator
from navd.sim.settings import SimSettings
from navd.sim.world import World
from navd.wire import AsyncClient, ClientError

__all__ = ["Session", "free_port", "session"]

READY_TIMEOUT_S = 120.0  # [s] a daemon starting on a busy machine (imports, its first kernels)
HELLO_TIMEOUT_S = 10.0  # [s] for the answer to one hello while the daemon starts
RETRY_S = 0.2  # [s] between attempts
LOG_TAIL_BYTES = 2000  # what of the daemon's log an error quotes
PORT_ATTEMPTS = 3  # free ports tried: another program may take one before the daemon does
PORT_TAKEN = "address already in use"  # what the daemon's log says then


class PortTakenError(SimError):
    """The daemon could not listen: the free port was taken before it bound it."""


def _merge(base: dict[str, Any], extra: Mapping[str, Any]) -> dict[str, Any]:
    merged = {k: dict(v) if isinstance(v, dict) else v for k, v in base.items()}
    for section, values in extra.items():
        merged.setdefault(section, {}).update(values)
    return merged


@dataclass
class Session:
    """What a running session offers: the simulator, the control client, the daemon's port,
    process and config, and the folder its maps go to."""

    sim: Simulator
    control: AsyncClient
    port: int
    daemon: asyncio.subprocess.Process
    config: NavdConfig
    maps: Path
    sim_task: asyncio.Task[None]

    def check(self) -> None:
        """Raise if the simulator or the daemon has stopped: a loop waiting for simulated
        time to pass would otherwise wait for ever.

        Raises:
            SimError: naming what stopped and why.
        """
        if self.sim_task.done():
            error = None if self.sim_task.cancelled() else self.sim_task.exception()
            raise SimError(f"the simulator stopped: {error!r}") from error
        if self.daemon.returncode is not None:
            raise SimError(f"navd exited with code {self.daemon.returncode} (see its log)")


@contextlib.asynccontextmanager
async def session(
    world: World,
    work_dir: Path,
    *,
    overrides: Mapping[str, Any] | None = None,
    sim_settings: Mapping[str, Any] | None = None,
    log_path: Path | None = None,
    lockstep: bool = False,
    hold_clock: bool = False,
    start: Pose2 | None = None,
) -> AsyncIterator[Session]:
    """Run the daemon and the simulator in ``world`` (see the module docstring).

    Args:
        world: the simulated world.
        work_dir: folder for the config, the chassis link, the maps and the log.
        overrides: config sections merged over the session's own ({"planning": {...}}).
        sim_settings: SimSettings fields to change (noise, rates, seed).
        log_path: where the daemon's log goes (default ``work_dir/navd.log``).
        lockstep: the simulator drives the daemon's simulated clock (deterministic for a
            seed, as fast as the CPU allows) instead of both running in real time.
        hold_clock: in lockstep, time stays at 0 until ``s.sim.release_clock()`` (so a
            scenario can send its goal first); otherwise it starts once the control client
            is connected.
        start: where the robot starts (default: the world's start).
    """
    work_dir.mkdir(parents=True, exist_ok=True)
    for attempt in range(1, PORT_ATTEMPTS + 1):
        launch = await _launch(
            world, work_dir, overrides, sim_settings, log_path or work_dir / "navd.log",
            lockstep=lockstep, start=start,
        )  # fmt: skip
        try:
            control = await _welcomed_control(launch.port, launch.daemon, launch.log_path)
        except PortTakenError:
            await launch.close()
            if attempt < PORT_ATTEMPTS:
                continue  # another program took the free port first: take another
            raise
        except BaseException:
            await launch.close()
            raise
        break
    try:
        if not hold_clock:
            launch.sim.release_clock()
        yield Session(
            launch.sim,
            control,
            launch.port,
            launch.daemon,
            launch.config,
            work_dir / "maps",
            launch.sim_task,
        )
    finally:
        await control.close()
        await launch.close()


@dataclass
class _Launch:
    """A simulator and a daemon started together, on one port."""

    sim: Simulator
    sim_task: asyncio.Task[None]
    stop: asyncio.Event
    daemon: asyncio.subprocess.Process
    port: int
    config: NavdConfig
    log_path: Path
    lockstep: bool

    async def close(self) -> None:
        """Stop both: in lockstep time stops first, so the daemon stops at a known instant;
        the daemon gets SIGTERM, and SIGKILL after 15 s."""
        if self.lockstep:
            self.stop.set()
            with contextlib.suppress(asyncio.CancelledError):
                await self.sim_task
        if self.daemon.returncode is None:
            self.daemon.send_signal(signal.SIGTERM)
            try:
                await asyncio.wait_for(self.daemon.wait(), 15.0)
            except TimeoutError:
                self.daemon.kill()
                await self.daemon.wait()
        self.stop.set()
        with contextlib.suppress(asyncio.CancelledError):
            await self.sim_task


async def _launch(
    world: World,
    work_dir: Path,
    overrides: Mapping[str, Any] | None,
    sim_settings: Mapping[str, Any] | None,
    log_path: Path,
    *,
    lockstep: bool,
    start: Pose2 | None,
) -> _Launch:
    """Write the daemon's config on a free port, start the simulator, then the daemon."""
    port = free_port()
    tty = work_dir / "chassis-tty"
    raw = _merge(
        {
            "chassis": {"enabled": True, "port": str(tty), "feedback": "encoders"},
            "tcp": {"port": port},
            # free ports for each simulated robot's live view and operator page
            "viz": {"port": 0, "page_port": 0},
            "slam": {"map_dir": str(work_dir / "maps")},
            "lifecycle": {"event_loop": "asyncio"},
            "logging": {"format": "json"},
        },
        overrides or {},
    )
    if lockstep:
        raw = _merge(raw, {"lifecycle": {"clock": "simulated"}, "tcp": {"read_coalesce_ms": 0.0}})
    config = NavdConfig.model_validate(raw)
    config_path = work_dir / "navd.toml"
    config_path.write_text(tomli_w.dumps(raw), encoding="utf-8")
    settings = SimSettings(
        port=port,
        tty_link=tty,
        clock="lockstep" if lockstep else "real",
        **dict(sim_settings or {}),
    )
    sim = Simulator(world, config, settings, start)
    stop = asyncio.Event()
    sim_task = asyncio.create_task(sim.run(stop))
    await asyncio.sleep(0.2)  # the pseudo-terminal link exists before the daemon opens it
    with log_path.open("wb") as log:
        daemon = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "navd", "run", "--config", str(config_path),
            stdout=log, stderr=log,
        )  # fmt: skip
    return _Launch(sim, sim_task, stop, daemon, port, config, log_path, lockstep)


async def _welcomed_control(
    port: int, daemon: asyncio.subprocess.Process, log_path: Path
) -> AsyncClient:
    """A control client the daemon welcomed: tried again (a daemon still starting may not
    listen yet, or be too busy to answer a hello in time) until READY_TIMEOUT_S, and given up
    at once if the daemon exits.

    Raises:
        SimError: the daemon exited, or did not welcome the client in time; with the end of
            its log.
    """
    deadline = time.monotonic() + READY_TIMEOUT_S
    while True:
        if daemon.returncode is not None:
            tail = _tail(log_path)
            error = PortTakenError if PORT_TAKEN in tail else SimError
            raise error(
                f"navd exited with code {daemon.returncode} before it welcomed a client; "
                f"its log ends: {tail}"
            )
        try:
            return await AsyncClient.connect(
                "127.0.0.1", port, device_id="sim-control", timeout_s=HELLO_TIMEOUT_S
            )
        except (ClientError, OSError) as err:
            if time.monotonic() > deadline:
                raise SimError(
                    f"navd did not welcome a control client on port {port} within "
                    f"{READY_TIMEOUT_S} s (last: {err}); its log ends: {_tail(log_path)}"
                ) from err
        await asyncio.sleep(RETRY_S)


def _tail(log_path: Path) -> str:
    """The last LOG_TAIL_BYTES of the daemon's log, or why there is none."""
    try:
        data = log_path.read_bytes()
    except OSError as err:
        return f"(unreadable: {err})"
    return data[-LOG_TAIL_BYTES:].decode("utf-8", "replace") or "(empty)"
