"""The collision guard: independent of the planner, it zeroes or slows a command that would
bring scan points into the stop or slow-down zone (Nav2's collision monitor idea).

For a command (v, ω) the footprint is swept along its arc over the time the robot needs to
brake (|v| / max linear deceleration, |ω| / max angular deceleration, plus one command
period), and the smallest distance from the swept footprint to any scan point is compared
with ``safety.stop_distance_m`` and ``safety.slowdown_distance_m``. Only motion that brings the
robot closer than it already is counts: backing away from a wall is always allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import Footprint, SensorMounts, scan_points
from navd.planning._guard_kernels import sweep_clearance

__all__ = ["GuardSettings", "guard_scale", "warm_up_guard"]

FloatArray = npt.NDArray[np.float64]

# The sweep is sampled at least this finely [m of travel] and [rad of turn].
SWEEP_STEP_M = 0.02
SWEEP_STEP_RAD = 0.05
# Only what a braking robot can reach matters: scan points farther than this are not kept [m].
GUARD_REACH_M = 3.0


@dataclass(frozen=True, slots=True)
class GuardSettings:
    """The guard's plain values (see the module docstring)."""

    footprint: Footprint
    stop_m: float
    slowdown_m: float
    slowdown_factor: float
    linear_decel_mps2: float
    angular_decel_radps2: float
    period_s: float
    enabled: bool
    mounts: SensorMounts
    speed_mask: str | None = None
    max_speed_mps: float = math.inf


def guard_scale(
    points_m: FloatArray, linear_mps: float, angular_radps: float, s: GuardSettings
) -> tuple[float, str]:
    """The factor (0, the slow-down factor or 1) for a command, and why.

    Args:
        points_m: [m] M x 2 scan points in the robot frame.
        linear_mps, angular_radps: the command.
        s: the guard's settings.
    """
    if not s.enabled or points_m.shape[0] == 0 or (linear_mps == 0.0 and angular_radps == 0.0):
        return 1.0, ""
    if not sweep_clearance.signatures:  # asked on the event loop, which must not compile
        return 0.0, "collision guard starting (its kernel is not loaded yet): stop"
    braking = max(
        abs(linear_mps) / s.linear_decel_mps2, abs(angular_radps) / s.angular_decel_radps2
    )
    duration = braking + s.period_s
    travel = abs(linear_mps) * duration + s.footprint.circumradius_m * abs(angular_radps) * duration
    samples = max(
        math.ceil(travel / SWEEP_STEP_M),
        math.ceil(abs(angular_radps) * duration / SWEEP_STEP_RAD),
        1,
    )
    fp = s.footprint
    now, swept = sweep_clearance(
        points_m,
        linear_mps,
        angular_radps,
        duration,
        samples,
        fp.kind,
        fp.half_length_m,
        fp.half_width_m,
    )
    if swept >= now - 1e-6:
        return 1.0, ""  # moving away, or along: nothing comes closer
    if swept < s.stop_m:
        return 0.0, f"obstacle {max(swept, 0.0):.2f} m from the footprint on the way: stop"
    if swept < s.slowdown_m:
        return s.slowdown_factor, f"obstacle {swept:.2f} m from the footprint on the way: slow"
    return 1.0, ""


def warm_up_guard(settings: GuardSettings) -> None:
    """Load the guard's kernels: the sweep (``guard_scale`` stops the robot until it is
    loaded) and the scan's points (numpy does them until then)."""
    fp = settings.footprint
    points = scan_points(np.full(8, 1.0), -math.pi, math.pi / 4, range_min=0.1, range_max=8.0)
    sweep_clearance(points.hits, 0.1, 0.1, 0.5, 4, fp.kind, fp.half_length_m, fp.half_width_m)
    guard_scale(points.hits, 0.1, 0.1, settings)
