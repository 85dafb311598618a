"""The scan mapper's handling of new ground: it keeps mapping where the map cannot explain a
scan yet, instead of dropping every scan and staying lost."""

from __future__ import annotations

import math

import numpy as np

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2, ScanPoints, scan_points
from navd.slam.mapper import ScanMapper
from navd.slam.occupancy import OccupancyGrid
from navd.slam.settings import MapperSettings

# A corridor about 2 m wide and 40 m long, closed at both ends (walls off cell borders).
W = 1.02
CORRIDOR = np.array(
    [
        [-1.0, -W, 40.0, -W],
        [-1.0, W, 40.0, W],
        [-1.0, -W, -1.0, W],
        [40.0, -W, 40.0, W],
    ]
)
SENSOR_RANGE_M = 4.0


def front_scan(pose: Pose2) -> ScanPoints:
    """What a 180° lidar facing forward with a 4 m range sees at ``pose`` in the corridor."""
    angle_min, increment, ranges = cast(pose, 360, CORRIDOR)
    front = slice(90, 271)  # -90° .. +90°
    return scan_points(
        ranges[front],
        angle_min + 90 * increment,
        increment,
        range_min=0.1,
        range_max=SENSOR_RANGE_M,
    )


def test_known_fraction_tells_mapped_from_never_seen_ground() -> None:
    grid = OccupancyGrid(0.05)
    grid.insert(Pose2(0.0, 0.0, 0.0), front_scan(Pose2(0.0, 0.0, 0.0)))
    on_mapped_walls = np.array([[1.0, W], [2.0, -W], [3.0, W]])
    far_down_the_corridor = np.array([[20.0, W], [25.0, -W]])
    assert grid.known_fraction(Pose2(0.0, 0.0, 0.0), on_mapped_walls) == 1.0
    assert grid.known_fraction(Pose2(0.0, 0.0, 0.0), far_down_the_corridor) == 0.0
    both = np.vstack([on_mapped_walls, far_down_the_corridor])
    assert grid.known_fraction(Pose2(0.0, 0.0, 0.0), both) == 0.6
    # The same points seen from 30 m further on land where nothing was mapped.
    assert grid.known_fraction(Pose2(30.0, 0.0, 0.0), on_mapped_walls) == 0.0


def test_a_robot_outrunning_its_map_keeps_mapping_from_odometry() -> None:
    # 3.8 m between scans with a 4 m sensor: each scan sees almost only walls the map has
    # never seen, too little to match against, from a spot the last scan saw. The mapper
    # must still grow the map down the corridor.
    settings = MapperSettings.defaults(max_range_m=SENSOR_RANGE_M, keep_trajectory=True)
    mapper = ScanMapper(settings)
    truth = [Pose2(3.8 * i, 0.0, 0.0) for i in range(9)]  # 0 .. 30.4 m
    for i, pose in enumerate(truth):
        mapper.add(2.0 * i, front_scan(pose), pose)  # 1.9 m/s: fast, not implausible
    assert mapper.counts.exploring == len(truth) - 1
    assert mapper.counts.keyframes == len(truth)
    # The far walls are in the map, where they are (beams 1° apart hit a wall 3 m ahead
    # about 0.2 m apart, so look within 0.25 m along it).
    for x, y in [(32.0, W), (33.0, -W), (34.0, W)]:
        col, row = mapper.grid.cells(np.array([[x, y]]))[0]
        assert (mapper.grid.to_array()[row, col - 5 : col + 6] > 0.0).any(), (x, y)
    end = mapper.trajectory()[-1]
    assert math.hypot(end.x - truth[-1].x, end.y - truth[-1].y) < 0.1


def test_a_scan_from_a_pose_off_the_mapped_ground_is_not_mapped() -> None:
    # Odometry that puts the robot 20 m beyond anything mapped is more likely wrong than new:
    # its scan is dropped rather than mapped at a doubtful pose.
    mapper = ScanMapper(MapperSettings.defaults(max_range_m=SENSOR_RANGE_M))
    mapper.add(0.0, front_scan(Pose2(0.0, 0.0, 0.0)), Pose2(0.0, 0.0, 0.0))
    before = mapper.grid.to_array()
    result = mapper.add(10.0, front_scan(Pose2(2.0, 0.0, 0.0)), Pose2(22.0, 0.0, 0.0))
    assert not result.matched and not result.keyframe
    assert (mapper.counts.exploring, mapper.counts.weak_matches) == (0, 1)
    np.testing.assert_array_equal(mapper.grid.to_array(), before)


def room_scan(pose: Pose2) -> ScanPoints:
    """What a full-circle lidar sees at ``pose`` in the bench room (12 m x 8 m)."""
    angle_min, increment, ranges = cast(pose)
    return scan_points(ranges, angle_min, increment, range_min=0.1, range_max=12.0)


def test_a_robot_whose_wheels_slipped_further_than_the_window_is_found_again() -> None:
    # The wheels slip 0.8 m (a bump, a lifted wheel): the odometry is 0.8 m ahead of the
    # robot from then on, beyond the 0.3 m tracking window. There the scan fits the map at
    # 0.5, where the scans before fit at 0.98: doubtful. The wider search finds the robot
    # where the scan fits as before, and tracking goes on from there.
    mapper = ScanMapper(MapperSettings.defaults(keep_trajectory=True))
    truth = [Pose2(-4.0 + 0.1 * i, -1.0, 0.0) for i in range(60)]
    slip = Pose2(0.8, 0.0, 0.0)
    for i, pose in enumerate(truth):
        odom = pose.compose(slip) if i >= 30 else pose
        mapper.add(float(i), room_scan(pose), odom)
    assert mapper.counts.repaired == 1
    assert mapper.counts.weak_matches == mapper.counts.exploring == 0
    for pose, true in zip(mapper.trajectory()[30:], truth[30:], strict=True):
        assert math.hypot(pose.x - true.x, pose.y - true.y) < 0.05


def test_a_map_rebuilt_from_its_keyframes_keeps_the_loaded_map_under_them() -> None:
    # A saved map: the room seen from one corner, and a mark this run never sees (a block
    # beyond the walls). A loop closure redraws the map from this run's keyframes; the
    # loaded map, which has no keyframes, must stay under them (before, it was dropped).
    loaded = OccupancyGrid(0.05)
    loaded.insert(Pose2(-5.0, -3.0, 0.0), room_scan(Pose2(-5.0, -3.0, 0.0)))
    mark = np.array([[8.0, 0.0]])
    col, row = loaded.cells(mark)[0]
    cells = loaded.to_array()
    cells[row - 2 : row + 3, col - 2 : col + 3] = 3.5
    loaded = OccupancyGrid.from_array(cells, loaded.origin_x, loaded.origin_y, 0.05)
    mapper = ScanMapper(MapperSettings.defaults())
    mapper.load(loaded)
    start = Pose2(3.5, -0.5, math.pi / 2)
    mapper.set_pose(start)
    for i in range(40):
        angle = 2 * math.pi * i / 80  # half a loop around the room
        pose = Pose2(4.0 * math.cos(angle) - 0.5, 2.2 * math.sin(angle) - 0.5, angle + math.pi / 2)
        mapper.add(0.1 * i, room_scan(pose), pose)
    assert mapper.counts.matched == 40 and mapper.counts.keyframes > 5
    drawn = mapper.grid.to_array()
    mapper.rebuild_map()
    col, row = mapper.grid.cells(mark)[0]
    assert mapper.grid.to_array()[row, col] == 3.5
    # The rest is as it was drawn scan by scan: the loaded map, then each keyframe over it.
    np.testing.assert_allclose(mapper.grid.to_array(), drawn, atol=1e-5)


def test_a_blind_scan_first_and_between_is_taken_and_mapping_goes_on() -> None:
    # A covered lidar (every range 0: no hit, no miss) at the start and once more later: the
    # mapper keeps the pose it is given and maps the next real scans as ever.
    mapper = ScanMapper(MapperSettings.defaults())
    blind = scan_points(np.zeros(360), -math.pi, math.pi / 180, range_min=0.1, range_max=12.0)
    assert blind.hits.size == blind.misses.size == 0
    first = mapper.add(0.0, blind, Pose2(0.0, 0.0, 0.0))
    assert first.pose == Pose2(0.0, 0.0, 0.0)
    for i in range(1, 6):  # 0.4 m apart: each a keyframe
        pose = Pose2(0.4 * i, 0.0, 0.0)
        mapper.add(0.1 * i, blind if i == 3 else room_scan(pose), pose)
    assert mapper.grid.to_array().max() > 0  # the walls are mapped
    assert mapper.pose is not None and math.hypot(mapper.pose.x - 2.0, mapper.pose.y) < 0.05
