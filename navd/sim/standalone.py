"""``navd sim``: the simulator as a program of its own, beside a running ``navd run``.

It reads the daemon's own config file, so both agree on everything: the TCP server it
connects its sensors to (and the token, if any), the chassis port where it links its end of
the pseudo-terminal, the robot's size and calibration, the lidar mount and the GPS datum.
With ``lifecycle.clock = "simulated"`` in that config it drives the daemon's clock in
lockstep; otherwise both run in real time. It runs until SIGINT or SIGTERM, then writes the
ground truth (if asked) and prints a summary.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import signal
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from navd.config import NavdConfig
from navd.sim.runner import Simulator
from navd.sim.settings import SimSettings
from navd.sim.world import World

__all__ = ["WAITING_S", "run_sim", "write_truth"]

WAITING_S = 5.0  # [s] without a sensor welcomed, the caller is told what is wrong


def _connect_host(listen_host: str) -> str:
    """Where to reach a server listening on ``listen_host`` from this machine."""
    return "127.0.0.1" if listen_host in ("0.0.0.0", "::", "") else listen_host


def run_sim(
    world: World,
    config: NavdConfig,
    *,
    seed: int = 0,
    truth_path: Path | None = None,
    limit_s: float | None = None,
    waiting: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Play the robot in ``world`` for the daemon configured by ``config``.

    Args:
        world: the simulated world.
        config: the daemon's config (the file ``navd run`` was given).
        seed: seeds every noise source.
        truth_path: where to write the ground truth CSV (time, x, y, yaw) at the end.
        limit_s: [s] stop after this much simulated time (None: until a signal).
        waiting: told, once, what is wrong when no sensor has reached the daemon
            ``WAITING_S`` after the start (the sensors keep trying meanwhile, as a robot's
            do while navd starts).

    Returns:
        A summary: simulated time, collisions, minimum clearance, wheel lines, and the
        sensors navd welcomed (none: it was never reached).

    Raises:
        SimError: the chassis link cannot be made, or the daemon refused or stopped
            answering its clock.
    """
    settings = SimSettings(
        host=_connect_host(config.tcp.host),
        port=config.tcp.port,
        token=config.tcp.token,
        tty_link=Path(config.chassis.port),
        seed=seed,
        clock="lockstep" if config.lifecycle.clock == "simulated" else "real",
    )
    sim = Simulator(world, config, settings)
    address = f"{settings.host}:{settings.port}"

    async def main() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        sim.release_clock()
        # On simulated time the lockstep ends on the step at limit_s itself, so a run's summary
        # is the same every time; real time is watched (to within 0.05 s).
        watched = limit_s if sim.lockstep is None else None
        if watched is not None:

            async def watch() -> None:
                while sim.now() < watched:
                    await asyncio.sleep(0.05)
                stop.set()

            watcher = loop.create_task(watch())

        async def unreached() -> None:
            await asyncio.sleep(WAITING_S)
            if not sim.links.welcomed and waiting is not None:
                waiting(sim.links.last_refusal or f"no answer from navd at {address} yet")

        checker = loop.create_task(unreached())
        try:
            await sim.run(stop, until_s=limit_s)
        finally:
            checker.cancel()
            if watched is not None:
                watcher.cancel()

    asyncio.run(main())
    if truth_path is not None:
        write_truth(sim, truth_path)
    return {
        "world": world.name,
        "clock": settings.clock,
        "sim_time_s": round(sim.now(), 3),
        "collisions": sim.body.collisions,
        "min_clearance_m": round(sim.body.min_clearance_m, 3),
        "chassis_lines": sim.chassis_lines,
        "final_pose": [round(v, 4) for v in (sim.body.x_m, sim.body.y_m, sim.body.yaw_rad)],
        "sensors_connected": sorted(sim.links.welcomed),
        "last_refusal": sim.links.last_refusal if not sim.links.welcomed else "",
        "navd_address": address,
    }


def write_truth(sim: Simulator, path: Path) -> None:
    """The recorded ground truth as CSV (``t_s,x_m,y_m,yaw_rad``), written atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = ["t_s,x_m,y_m,yaw_rad"]
    lines += [f"{t:.3f},{x:.5f},{y:.5f},{yaw:.6f}" for t, x, y, yaw in sim.truth]
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write("\n".join(lines) + "\n")
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
