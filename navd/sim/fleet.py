"""Several simulated robots in one world, each with its own navd process, chassis
pseudo-terminal and sensors, all VDA 5050 vehicles on one broker.

``async with fleet_sessions(world, folder, robots, broker_url) as fleet:`` runs one
``session`` per robot (real time: each daemon keeps its own clock) and makes every robot's
body a disc the others' lidars see and bump into.
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.sim.sim_session import Session, session
from navd.sim.world import World

__all__ = ["fleet_sessions"]


@contextlib.asynccontextmanager
async def fleet_sessions(
    world: World,
    work_dir: Path,
    robots: Sequence[tuple[str, Pose2]],
    broker_url: str,
    *,
    overrides: Mapping[str, Any] | None = None,
    sim_settings: Mapping[str, Any] | None = None,
) -> AsyncIterator[list[Session]]:
    """Run a robot per (serial number, start pose) of ``robots`` (see the module docstring).

    Args:
        world: the world they share.
        work_dir: a folder per robot is made in it (config, log, maps).
        robots: each robot's VDA 5050 serial number and start pose.
        broker_url: the MQTT broker they all join.
        overrides: config sections merged over each robot's (the fleet section's names and
            broker are set here).
        sim_settings: SimSettings fields for every robot (each gets its own noise seed).
    """
    async with contextlib.AsyncExitStack() as stack:
        sessions: list[Session] = []
        for k, (serial, start) in enumerate(robots):
            own: dict[str, Any] = {
                **dict(overrides or {}),
                "fleet": {
                    **dict((overrides or {}).get("fleet", {})),
                    "enabled": True,
                    "broker_url": broker_url,
                    "serial_number": serial,
                },
                "robot": {**dict((overrides or {}).get("robot", {})), "name": serial},
            }
            settings = {"seed": k, **dict(sim_settings or {})}
            s = await stack.enter_async_context(
                session(
                    world,
                    work_dir / serial,
                    overrides=own,
                    sim_settings=settings,
                    start=start,
                )
            )
            sessions.append(s)
        for s in sessions:
            s.sim.robot.neighbours = _others(s, sessions)
        yield sessions


def _others(me: Session, everyone: list[Session]) -> Any:
    """The discs of every robot but ``me``: where their bodies are now."""
    others = [s for s in everyone if s is not me]

    def discs() -> npt.NDArray[np.float64]:
        if not others:
            return np.empty((0, 3))
        return np.array(
            [(s.sim.body.x_m, s.sim.body.y_m, s.sim.robot.footprint.circumradius_m) for s in others]
        )

    return discs
