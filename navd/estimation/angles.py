"""Angles on the circle, and the one conversion from compass bearings to map yaw.

Map yaw is counter-clockwise from the map's +x axis; a compass bearing is clockwise from
north. The two are never mixed: a bearing becomes a yaw only through ``bearing_to_yaw``.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = ["bearing_to_yaw", "circular_mean", "wrap_angle", "wrap_angles"]

FloatArray = npt.NDArray[np.float64]
_TAU = 2.0 * math.pi


def wrap_angle(angle_rad: float) -> float:
    """``angle_rad`` wrapped into [-pi, pi)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def wrap_angles(angles_rad: FloatArray) -> FloatArray:
    """Element-wise ``wrap_angle`` of an array."""
    # Python floats, not numpy scalars: half the cost on the short arrays of a UKF step.
    return np.remainder(angles_rad + math.pi, _TAU) - math.pi


def circular_mean(angles_rad: FloatArray, weights: FloatArray) -> float:
    """The weighted mean of angles through their sines and cosines, in [-pi, pi].

    Weights may be negative (unscented transform weights); only their sums matter.
    """
    return math.atan2(float(weights @ np.sin(angles_rad)), float(weights @ np.cos(angles_rad)))


def bearing_to_yaw(
    bearing_deg: float,
    *,
    declination_deg: float,
    magnetic: bool,
    grid_convergence_rad: float,
    map_rotation_rad: float,
) -> float:
    """Convert a compass bearing into a yaw in the map frame.

    Args:
        bearing_deg: [deg] heading clockwise from north (magnetic or true).
        declination_deg: [deg] true north minus magnetic north, east positive; added when
            ``magnetic`` is True.
        magnetic: True if the bearing is measured from magnetic north.
        grid_convergence_rad: [rad] angle from true north to grid (UTM) north, counter-
            clockwise positive, at the robot's location (see ``GeoFrame``).
        map_rotation_rad: [rad] the map's +x axis, counter-clockwise from grid east.

    Returns:
        [rad] yaw counter-clockwise from the map's +x axis, in [-pi, pi).
    """
    true_bearing_deg = bearing_deg + (declination_deg if magnetic else 0.0)
    # East-north-up yaw of the true bearing: north is +pi/2, east is 0, clockwise flips sign.
    enu_yaw = math.pi / 2.0 - math.radians(true_bearing_deg)
    # A direction's angle from grid east is its angle from true east minus the grid's turn.
    grid_yaw = enu_yaw - grid_convergence_rad
    return wrap_angle(grid_yaw - map_rotation_rad)
