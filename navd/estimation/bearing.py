"""The one conversion from compass bearings to map yaw.

Map yaw is counter-clockwise from the map's +x axis; a compass bearing is clockwise from
north. The two are never mixed: a bearing becomes a yaw only through ``bearing_to_yaw``.
"""

from __future__ import annotations

import math

from navd.geometry import wrap_angle

__all__ = ["bearing_to_yaw"]


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
