"""The distance planned motion keeps from obstacles."""

from __future__ import annotations

from navd.config import SafetyConfig

__all__ = ["keep_clear_m"]


def keep_clear_m(safety: SafetyConfig) -> float:
    """[m] the distance planned motion keeps between the footprint and obstacles.

    ``safety.collision_distance_m``, raised to the collision guard's ``stop_distance_m`` when
    the guard is on: a route or rollout the guard would stop could never be driven, and the
    planner would insist on it forever.
    """
    if safety.use_collisions:
        return max(safety.collision_distance_m, safety.stop_distance_m)
    return safety.collision_distance_m
