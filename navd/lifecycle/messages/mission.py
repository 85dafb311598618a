"""Missions: an ordered list of steps driven one after the other, and their progress."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from navd.lifecycle.messages.base import Message
from navd.wire.replies import MissionInfo

__all__ = [
    "BEACON_STEPS",
    "MISSION_ACTIONS",
    "MissionCommand",
    "MissionRequest",
    "MissionStatus",
    "MissionStep",
]

StepKind = Literal[
    "goto", "goto_gps", "wait", "pause", "approach", "beacon", "gate", "visit_beacons"
]
BEACON_STEPS = ("beacon", "gate", "visit_beacons")
FailurePolicy = Literal["skip", "retry", "abort"]
MISSION_ACTIONS = ("pause", "resume", "cancel", "continue")


@dataclass(frozen=True, slots=True, kw_only=True)
class MissionStep:
    """One step of a mission.

    Attributes:
        kind: "goto" (a map pose), "goto_gps" (a WGS84 position), "wait" (``seconds``),
            "pause" (until a person says continue; ``message`` tells them what for),
            "approach" (drive near (x, y), then the last ``stop_distance_m`` short of it
            slowly, at ``speed_mps``, along ``yaw_rad`` when given), "beacon" (drive to
            the beacon ``beacons[0]``, stopping ``stop_distance_m`` short, facing it),
            "gate" (pass between the two ``beacons``, square to the line joining them),
            "visit_beacons" (each of ``beacons`` in the nearest-next order, or every beacon
            with a place when empty).
        x_m, y_m, yaw_rad: [m, m, rad] the pose of goto and approach (yaw None: any).
        latitude_deg, longitude_deg: [deg] goto_gps's position.
        seconds: [s] wait's length.
        message: what a pause asks the person to do.
        stop_distance_m: [m] approach: how far short of (x, y) to stop.
        speed_mps: [m/s] top speed of the step (approach: of its slow part); None: the robot's.
        on_failure: what a failed step does: "skip" it, "retry" it up to ``retries`` times
            (then the mission fails), or "abort" the mission.
        retries: attempts after the first, for "retry".
        beacons: the beacon ids of beacon, gate and visit_beacons.
    """

    kind: StepKind
    x_m: float = math.nan
    y_m: float = math.nan
    yaw_rad: float | None = None
    latitude_deg: float = math.nan
    longitude_deg: float = math.nan
    seconds: float = 0.0
    message: str = ""
    stop_distance_m: float = 0.0
    speed_mps: float | None = None
    on_failure: FailurePolicy = "abort"
    retries: int = 0
    beacons: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, kw_only=True)
class MissionRequest(Message):
    """Run a mission (replacing any running one).

    Attributes:
        mission_id: its name on the wire and in the goals it sends.
        name: what the person called it.
        steps: the steps, in order.
        rounds: how many times through the steps; 0: until cancelled (a patrol).
        client_id: who asked.
    """

    mission_id: str
    name: str
    steps: tuple[MissionStep, ...]
    rounds: int = 1
    client_id: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class MissionCommand(Message):
    """Pause, resume or cancel the running mission, or let a paused step continue.

    Attributes:
        action: one of MISSION_ACTIONS.
        client_id: who asked.
    """

    action: str
    client_id: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class MissionStatus(Message):
    """Where a mission is, published on every change of step or state and as it drives.

    Attributes:
        info: the mission's progress, as control clients receive it (``navd.wire``'s
            ``MissionInfo`` is its one definition: state, step and round, the event that
            just happened, the distance and time to the step's goal, None when unknown).
    """

    info: MissionInfo
