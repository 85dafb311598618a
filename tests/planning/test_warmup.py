"""The planning warm-up compiles what the planner then runs: in a fresh process, planning on
an inflated room (the bucket search) and on open floor (jump point search), and replanning
on each (the last route checked and continued), the local planner on every kind of window
and the route's blocked check, after it compiles nothing more, so a first goal never waits
for the compiler."""

from __future__ import annotations

import textwrap

from tests.conftest import fresh_process_output

SCRIPT = textwrap.dedent(
    """
    import numpy as np
    from navd.config import NavdConfig
    from navd.geometry.pose import Pose2
    from navd.planning import (
        _astar_kernels, _bitgrid_kernels, _bucket_kernels, _distance_kernels, _dwa_kernels
    )
    from navd.planning.costmap import GridFrame, build_costmap
    from navd.planning.dwa import LocalPlanner, Window, path_field
    from navd.planning.global_planner import GlobalPlanner
    from navd.planning.route import Route
    from navd.planning.settings import (
        costmap_settings, dwa_settings, search_settings, velocity_profile
    )
    from navd.planning.warmup import warm_up

    modules = (
        _astar_kernels, _bitgrid_kernels, _bucket_kernels, _distance_kernels, _dwa_kernels
    )
    kernels = [
        getattr(m, n) for m in modules for n in dir(m) if hasattr(getattr(m, n), "signatures")
    ]
    warm_up()
    warmed = {f.__name__: len(f.signatures) for f in kernels}
    config = NavdConfig()
    settings = costmap_settings(config.planning, config.robot, config.safety)
    search = search_settings(config.planning)
    walls = np.zeros((120, 90), dtype=np.bool_)
    walls[40, 10:80] = True
    frame = GridFrame(0.05, 0.0, 0.0, 120, 90)
    for obstacles in (walls, np.zeros_like(walls)):
        costmap = build_costmap(frame, obstacles, np.zeros_like(obstacles), settings)
        planner = GlobalPlanner()
        planner.plan(costmap, (0.5, 0.5), (4.0, 5.5), search)
        rebuilt = build_costmap(frame, obstacles, np.zeros_like(obstacles), settings)
        assert planner.plan(rebuilt, (0.55, 0.5), (4.0, 5.5), search).reused
    # the local planner: every kind of window, read-only and strided obstacle points
    local = LocalPlanner(
        dwa_settings(config.planning, config.robot, config.safety),
        velocity_profile(config.planning, config.robot).yaw_rate_table,
    )
    wall = np.column_stack([np.full(40, 1.0), np.linspace(-1.0, 1.0, 40), np.zeros(40)])
    wall.flags.writeable = False
    route = path_field(np.array([[0.0, 0.0], [2.0, 0.5]]))
    for window in (Window(0.5), Window(0.0, rotate_only=True), Window(0.3, 0.1, backward=True),
                   Window(0.4, min_speed_mps=0.2)):
        local.choose(Pose2(0.0, 0.0, 0.1), (0.2, 0.1), wall[:, :2], route,
                     Pose2(2.0, 0.5, 0.0), window)
    # the route's blocked check, on a scan's (read-only, strided) points
    Route(np.array([[0.0, 0.0], [2.0, 0.5]])).blocked(wall[:, :2], 0.3, 1.0)
    after = {f.__name__: len(f.signatures) for f in kernels}
    names = ("bucket_astar", "trace_steps", "jump_point_search", "trace_back", "shortcut")
    dwa = ("window_samples", "snap_near", "rollouts", "chamfer_distance", "bucket_points")
    for name in (*names, *dwa, "path_changed", "distance_to", "any_within"):
        assert warmed[name], (name, warmed)
    assert after == warmed, (warmed, after)
    print("ok")
    """
)


def test_the_warm_up_leaves_nothing_for_the_first_plans_to_compile() -> None:
    assert fresh_process_output(SCRIPT) == "ok"
