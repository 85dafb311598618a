"""Missions: ordered steps (goals, waits, pauses, approaches) run through the planner."""

from navd.missions.errors import MissionError, UnknownBeaconError
from navd.missions.node import MissionNode

__all__ = [
    "MissionError",
    "MissionNode",
    "UnknownBeaconError",
]
