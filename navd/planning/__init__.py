"""Planning: costmap, A* global planner, DWA local planner, velocity profile, stuck recovery.

No asyncio here: plain computation driven by the lifecycle layer.
"""

from navd.planning.errors import PlanningError

__all__ = ["PlanningError"]
