"""The SLAM warm-up loads what a first live scan and a first loop closure run: in a fresh
process, after it, scan odometry (kiss-icp, the motion prior without wheel odometry), a
mapper's first scans and a pose-graph solve import no module, so none of them holds the
interpreter lock for an import in the daemon."""

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
    from navd.slam.odometry import ScanOdometry, ScanOdometrySettings
    from navd.slam.pose_graph import Edge, optimize
    from navd.slam.settings import MapperSettings
    from navd.slam.warmup import warm_up

    warm_up()
    before = set(sys.modules)
    config = NavdConfig()
    odometry = ScanOdometry(ScanOdometrySettings.from_config(config))
    mapper = ScanMapper(MapperSettings.from_config(config))
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    ranges = 3.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))
    for k in range(3):
        scan = scan_points(ranges - 0.03 * k, -math.pi, 2 * math.pi / 360,
                           range_min=0.1, range_max=12.0)
        mapper.add(0.1 * k, scan, odometry.register(scan.hits))
    side = Pose2(2.0, 0.0, math.pi / 2)
    square = [Edge(k, (k + 1) % 4, side, (10.0, 10.0, 30.0)) for k in range(4)]
    poses = np.array([[0.0, 0.0, 0.0], [2.1, 0.0, 1.5], [2.0, 2.2, 3.1], [-0.1, 2.0, -1.6]])
    assert np.abs(optimize(poses, square)[2, :2] - [2.0, 2.0]).max() < 0.05
    imported = sorted(set(sys.modules) - before)
    assert not imported, f"a first scan or graph solve imported {imported}"
    print("ok")
    """
)


def test_a_first_scan_and_loop_closure_after_the_warm_up_import_nothing() -> None:
    assert fresh_process_output(SCRIPT, timeout_s=600.0) == "ok"
