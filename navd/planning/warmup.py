"""Compile (or load from the cache) every planning kernel before the first goal (the
collision guard's too: ``navd kernels`` fills the cache through this)."""

from __future__ import annotations

import math

import numpy as np

from navd.geometry import IDENTITY, scan_points
from navd.planning.costmap import GridFrame, build_costmap
from navd.planning.global_planner import GlobalPlanner
from navd.planning.goal import NavGoal
from navd.planning.guard import warm_up_guard
from navd.planning.navigator import Navigator
from navd.planning.settings import default_guard, default_planner

__all__ = ["warm_up"]


def warm_up() -> None:
    """Plan and take a few steps in a small room with a throwaway navigator (its scan read
    from ranges, as the planner reads every lidar's)."""
    settings = default_planner().navigator
    nav = Navigator(settings)
    occupancy = np.zeros((60, 60), dtype=np.int8)
    occupancy[[0, -1], :] = occupancy[:, [0, -1]] = 100
    nav.set_map(occupancy, 0.05, -1.5, -1.5)
    hits = scan_points(
        np.full(90, 1.4), -math.pi, 2 * math.pi / 90, range_min=0.1, range_max=8.0
    ).hits
    nav.add_scan(IDENTITY, hits, np.empty((0, 2)), 0.0)
    nav.set_goal(NavGoal("warm-up", 0.8, 0.5, 1.0))
    nav.accept_plan(0.0, nav.plan(0.0, IDENTITY))
    nav.accept_plan(0.1, nav.plan(0.1, IDENTITY))  # a replan: the last route checked, reused
    nav.add_scan(IDENTITY, hits, np.empty((0, 2)), 0.1)  # with a plan, its rays mark and clear
    for k in range(3):
        nav.step(0.05 * k, IDENTITY)
    assert nav.route is not None
    nav.route.blocked(nav.map_layers.scan_points, 0.3, 1.0)  # asked by the planner's loop
    # The room above is inflated, so A* went cell by cell, its open list in buckets; an open
    # floor with no obstacle is searched by jumping.
    nothing = np.zeros((20, 20), dtype=np.bool_)
    floor = build_costmap(GridFrame(0.05, 0.0, 0.0, 20, 20), nothing, nothing, settings.costmap)
    GlobalPlanner().plan(floor, (0.1, 0.1), (0.9, 0.7), settings.search)
    warm_up_guard(default_guard())
