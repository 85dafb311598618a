"""Following a mission on the real daemon in lockstep, as the mission tests do."""

from __future__ import annotations

from collections.abc import Callable

from navd.sim import Session
from navd.wire import ConnectionClosedError, MissionFrame, MissionStatusFrame, Reply

ENDED = ("completed", "failed", "canceled")


async def follow_mission(
    s: Session,
    mission: MissionFrame,
    limit_s: float,
    on_frame: Callable[[Reply], None] | None = None,
) -> list[MissionStatusFrame]:
    """Send ``mission``, let the simulated clock go and read the control connection until
    the mission ends or ``limit_s`` [s] of simulated time pass; every status of the mission.
    ``on_frame`` sees each frame read (status, mission status or other)."""
    ack = await s.control.request(mission)
    assert ack.mission_id == mission.mission_id
    s.sim.release_clock()
    seen: list[MissionStatusFrame] = []
    deadline = s.sim.now() + limit_s
    while s.sim.now() < deadline:
        s.check()
        try:
            frame = await s.control.receive(1.0)
        except TimeoutError:
            continue
        except ConnectionClosedError:
            break
        if on_frame is not None:
            on_frame(frame)
        if isinstance(frame, MissionStatusFrame) and frame.mission_id == mission.mission_id:
            seen.append(frame)
            if frame.state in ENDED:
                break
    return seen
