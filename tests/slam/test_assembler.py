"""Sweeps of several lidars gathered into one scan: a round per set, released early when a
lidar comes round again, older sweeps moved by the wheel odometry to the newest's time."""

from __future__ import annotations

import math

import numpy as np

from navd.geometry import FieldOfView, Pose2, ScanPoints
from navd.slam.assembler import ScanAssembler

FRONT = FieldOfView(0.1, 0.0, -0.5 * math.pi, math.pi)
REAR = FieldOfView(-0.1, 0.0, 0.5 * math.pi, math.pi)


def _sweep(x: float, y: float, view: FieldOfView) -> ScanPoints:
    return ScanPoints(np.array([[x, y]]), np.empty((0, 2)), view)


def test_a_round_is_released_once_every_lidar_has_swept() -> None:
    assembler = ScanAssembler(["front", "rear"])
    assert assembler.add("front", 1.00, _sweep(2.0, 0.0, FRONT), None) is None
    scan = assembler.add("rear", 1.02, _sweep(-2.0, 0.0, REAR), None)
    assert scan is not None and scan.lidars == 2 and scan.stamp == 1.02
    np.testing.assert_allclose(scan.points.hits, [[2.0, 0.0], [-2.0, 0.0]])
    assert scan.points.view.all_around  # two half circles back to back
    assert assembler.partial == 0


def test_older_sweeps_are_moved_to_where_the_robot_is_at_the_newest() -> None:
    # The robot drove 0.1 m forward and turned 0.1 rad between the two sweeps: a wall point
    # 2 m ahead at the first sweep is nearer, and to the right, at the second.
    assembler = ScanAssembler(["front", "rear"])
    before, after = Pose2(5.0, 1.0, 0.3), Pose2(5.0, 1.0, 0.3).compose(Pose2(0.1, 0.0, 0.1))
    assembler.add("front", 1.0, _sweep(2.0, 0.0, FRONT), before)
    scan = assembler.add("rear", 1.1, _sweep(-2.0, 0.0, REAR), after)
    assert scan is not None and scan.odom == after
    world = before.transform(np.array([[2.0, 0.0]]))  # where that wall point is
    np.testing.assert_allclose(scan.points.hits[0], after.inverse().transform(world)[0])
    np.testing.assert_allclose(scan.points.hits[1], [-2.0, 0.0])  # the newest stays put


def test_a_lidar_coming_round_again_releases_the_round_without_the_silent_one() -> None:
    assembler = ScanAssembler(["front", "rear"])
    assembler.add("front", 1.0, _sweep(2.0, 0.0, FRONT), None)
    scan = assembler.add("front", 1.1, _sweep(2.1, 0.0, FRONT), None)  # rear is quiet
    assert scan is not None and scan.lidars == 1 and scan.stamp == 1.0
    assert scan.points.view == FRONT  # one half circle is what it covers
    assert assembler.partial == 1
    # the new sweep waits for its round
    later = assembler.add("rear", 1.12, _sweep(-2.0, 0.0, REAR), None)
    assert later is not None and later.lidars == 2
    np.testing.assert_allclose(later.points.hits[0], [2.1, 0.0])
