"""The one conversion from compass bearings to map yaw.

Map yaw is counter-clockwise from the map's +x axis; a compass bearing is clockwise from
north. The two are never mixed: a bearing becomes a yaw only through ``bearing_to_yaw``.
"""

from __future__ import annotations

import math

from navd.config import WorldConfig
from navd.geometry import wrap_angle
from navd.lifecycle.messages import CompassHeading

__all__ = ["bearing_to_yaw", "compass_yaw"]


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


def compass_yaw(
    heading: CompassHeading,
    world: WorldConfig,
    *,
    grid_convergence_rad: float,
    mount_yaw_rad: float,
) -> float:
    """[rad] the robot's map yaw from a compass's ``heading``: the bearing converted
    (``bearing_to_yaw``, with the world's declination and map rotation), then turned by the
    compass's mount (its forward axis's yaw on the robot)."""
    yaw = bearing_to_yaw(
        heading.bearing_deg,
        declination_deg=world.magnetic_declination_deg,
        magnetic=not heading.true_north,
        grid_convergence_rad=grid_convergence_rad,
        map_rotation_rad=world.map_rotation_rad,
    )
    return wrap_angle(yaw - mount_yaw_rad)
