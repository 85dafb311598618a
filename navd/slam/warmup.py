"""Compile (or load from the cache) every SLAM kernel, and load the pose graph's sparse
solver, before the first live scan."""

from __future__ import annotations

import math

import numpy as np

from navd.geometry import Pose2, scan_points
from navd.slam.global_search import relocalize
from navd.slam.mapper import ScanMapper
from navd.slam.matcher import rival_ratio
from navd.slam.odometry import ScanOdometry, ScanOdometrySettings
from navd.slam.pose_graph import Edge, graph_distances, optimize
from navd.slam.settings import MapperSettings

__all__ = ["warm_up"]


def warm_up() -> None:
    """Run two scans of a small square room through a throwaway mapper and scan odometry,
    then find the second on the map (the global search of localization and loop closure), ask
    whether it fits elsewhere as well, and solve a three-pose loop.

    The pose graph imports scipy.sparse.linalg on first use, holding the interpreter lock
    while it does; done here, no loop closure pays for it (docs/performance.md, "The first
    message after an upgrade"). Each scan is the room shrunk by ``shift`` rather than the
    robot moved: what they compile and load does not depend on how far it is."""
    angles = -math.pi + 2 * math.pi * np.arange(90) / 90
    # Distance to the walls of a 4 m square room seen from its centre.
    ranges = 2.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))
    mapper = ScanMapper(MapperSettings.defaults(loop_closure=False))
    odometry = ScanOdometry(
        ScanOdometrySettings(voxel_size_m=0.1, max_range_m=10.0, min_range_m=0.1)
    )
    for shift in (0.0, 0.05):
        scan = scan_points(
            ranges - shift, -math.pi, 2 * math.pi / 90, range_min=0.1, range_max=10.0
        )
        mapper.add(shift, scan, odometry.register(scan.hits))
    odometry.compact()  # which registration does only once its map's table fills up
    found = relocalize(mapper.grid, scan.hits)
    # How well the scan fits elsewhere (tracking's repair, the lost search, loop closure).
    field = mapper.grid.likelihood_field(found.pose, 3.0, 0.05)
    rival_ratio(field, scan.hits, found.pose, radius_m=1.0, exclude_m=0.3)
    # A triangle: three 1 m sides, each turning 120 degrees, so the edges close exactly. The
    # poses start off it so the solver iterates, and the closing edge is robust, as a loop
    # closure's is, so the soft-L1 branch runs too.
    step = Pose2(1.0, 0.0, 2.0 * math.pi / 3.0)
    weights = (20.0, 20.0, 50.0)  # 1/sigma: 5 cm, 5 cm, 1.1 degrees
    loop = [Edge(0, 1, step, weights), Edge(1, 2, step, weights)]
    loop.append(Edge(2, 0, step, weights, robust=True))
    optimize(np.array([[0.0, 0.0, 0.0], [1.1, 0.0, 2.0], [0.5, 0.9, -2.2]]), loop)
    # The loop search's window: how far each keyframe is through the graph.
    graph_distances(loop, 3, 2)
