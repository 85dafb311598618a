"""``navd fleet``: a small fleet control that drives navd vehicles over VDA 5050 (a separate
process, never inside a robot)."""

from navd.fleetctl.control import drive_group
from navd.fleetctl.errors import FleetControlError, GroupGoalError
from navd.fleetctl.group_goal import GroupGoal
from navd.fleetctl.group_map import GroupMap
from navd.fleetctl.view import fleet_view

__all__ = [
    "FleetControlError",
    "GroupGoal",
    "GroupGoalError",
    "GroupMap",
    "drive_group",
    "fleet_view",
]
