"""The safety gate's vocabulary: holds (a safe stop named by its key, and its release), the
operator's emergency stop, and why the gate holds the robot now."""

from __future__ import annotations

from dataclasses import dataclass

from navd.lifecycle.messages.base import Message

__all__ = ["EmergencyStop", "SafeStop", "SafeStopCleared", "SafetyState"]


@dataclass(frozen=True, slots=True, kw_only=True)
class SafetyState(Message):
    """Why the safety gate holds the robot still; empty ``reasons`` means it may move."""

    reasons: tuple[str, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class SafeStop(Message):
    """The robot must stand still until a SafeStopCleared with the same ``key``.

    Attributes:
        reason: why, for people.
        source: who decided ("supervisor", "collision_guard"...).
        key: names this hold ("fault:planner"); a SafeStopCleared with it releases it.
    """

    reason: str
    source: str
    key: str


@dataclass(frozen=True, slots=True, kw_only=True)
class EmergencyStop(Message):
    """An operator's emergency stop: ``engaged``, the robot stops at once and stays still
    (its goal cancelled) until one releases it (``engaged`` false).

    Attributes:
        engaged: stop (True) or release (False).
        source: who (a control client's or viewer's id).
    """

    engaged: bool
    source: str


@dataclass(frozen=True, slots=True, kw_only=True)
class SafeStopCleared(Message):
    """The hold named ``key`` no longer applies."""

    key: str
    source: str
