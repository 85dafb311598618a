"""The SLAM warm-up loads what a first live scan and a first loop closure run: in a fresh
process, after it, scan odometry (the motion prior without wheel odometry), a
mapper's first scans (one with rays that saw nothing), a rival check, a search near a guess
and a pose-graph solve import no module and compile no grid kernel, so none of them holds
the interpreter lock for an import or a compile in the daemon."""

from __future__ import annotations

import textwrap

from tests.conftest import fresh_process_output

SCRIPT = textwrap.dedent(
    """
    import math
    import sys

    import numpy as np

    from navd.config import NavdConfig
    from navd.geometry.pose import Pose2
    from navd.geometry.scan import scan_points
    from navd.slam.mapper import ScanMapper
    from navd.slam.odometry import ScanOdometry
    from navd.slam.pose_graph import Edge, graph_distances, optimize
    from navd.slam.settings import MapperSettings, scan_odometry_settings
    from navd.slam import _grid_kernels
    from navd.slam.global_search import relocalize
    from navd.slam.matcher import rival_ratio
    from navd.slam.warmup import warm_up

    kernels = [
        getattr(_grid_kernels, n) for n in dir(_grid_kernels)
        if hasattr(getattr(_grid_kernels, n), "signatures")
    ]
    warm_up()
    warmed = {f.__name__: len(f.signatures) for f in kernels}
    before = set(sys.modules)
    config = NavdConfig()
    odometry = ScanOdometry(scan_odometry_settings(config.slam, config.lidar))
    mapper = ScanMapper(MapperSettings.from_config(config))
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    ranges = 3.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))
    for k in range(3):
        scan = scan_points(ranges - 0.03 * k, -math.pi, 2 * math.pi / 360,
                           range_min=0.1, range_max=12.0)
        mapper.add(0.1 * k, scan, odometry.register(scan.hits))
    # a doorway the lidar sees through: rays with nothing within range (misses)
    open_ranges = np.where(np.abs(angles) < 0.2, 30.0, ranges - 0.1)
    scan = scan_points(open_ranges, -math.pi, 2 * math.pi / 360, range_min=0.1, range_max=12.0)
    assert scan.misses.size
    mapper.add(0.3, scan, odometry.register(scan.hits))
    mapper.grid.insert(Pose2(0.4, 0.1, 0.3), scan)
    field = mapper.grid.likelihood_field(Pose2(0.0, 0.0, 0.0), 14.0, 0.05)
    rival_ratio(field, scan.hits, Pose2(0.0, 0.0, 0.0), radius_m=2.5, exclude_m=0.6)
    relocalize(mapper.grid, scan.hits, guess=Pose2(0.1, 0.0, 0.05))
    side = Pose2(2.0, 0.0, math.pi / 2)
    square = [Edge(k, (k + 1) % 4, side, (10.0, 10.0, 30.0)) for k in range(4)]
    poses = np.array([[0.0, 0.0, 0.0], [2.1, 0.0, 1.5], [2.0, 2.2, 3.1], [-0.1, 2.0, -1.6]])
    assert np.abs(optimize(poses, square)[2, :2] - [2.0, 2.0]).max() < 0.05
    assert graph_distances(square, 4, 0)[2] == 4.0  # the loop search's window
    imported = sorted(set(sys.modules) - before)
    assert not imported, f"a first scan or graph solve imported {imported}"
    after = {f.__name__: len(f.signatures) for f in kernels}
    for name in ("extent", "cells_and_box", "ray_update", "best_among", "doubled_max",
                 "branch_and_bound", "smear"):
        assert warmed[name], (name, warmed)
    assert after == warmed, (warmed, after)
    print("ok")
    """
)


def test_a_first_scan_and_loop_closure_after_the_warm_up_import_nothing() -> None:
    assert fresh_process_output(SCRIPT, timeout_s=600.0) == "ok"
