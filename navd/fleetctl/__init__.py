"""``navd fleet``: a small fleet control that drives navd vehicles over VDA 5050 (a separate
process, never inside a robot)."""

from navd.fleetctl.control import drive_group, fleet_view
from navd.fleetctl.errors import FleetControlError, GroupGoalError
from navd.fleetctl.group_goal import GroupGoal
from navd.fleetctl.group_map import GroupMap

__all__ = [
    "FleetControlError",
    "GroupGoal",
    "GroupGoalError",
    "GroupMap",
    "drive_group",
    "fleet_view",
]
