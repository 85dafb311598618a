"""When the refinement's field is drawn anew and when it is brought up to date."""

from __future__ import annotations

import math

import numpy as np

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2, ScanPoints, scan_points
from navd.offline.refinement import FIELD_MARGIN_M, FineRefinement
from navd.slam import Keyframe, MapperSettings, ScanMapper, voxel_downsample

SETTINGS = MapperSettings.defaults(keep_trajectory=True)  # a replay's


def _scan(pose: Pose2) -> ScanPoints:
    angle_min, increment, ranges = cast(pose, beams=720)
    return scan_points(ranges, angle_min, increment, range_min=0.1, range_max=12.0)


class _Counted(FineRefinement):
    """A refinement that counts the fine map's fields drawn anew and brought up to date."""

    def __init__(self, settings: MapperSettings) -> None:
        super().__init__(settings, settings.resolution_m / 2)
        self.drawn = self.updated = 0
        field, update = self.map.field, self.map.update

        def counted_field(*args, **kwargs):  # type: ignore[no-untyped-def]
            self.drawn += 1
            return field(*args, **kwargs)

        def counted_update(*args, **kwargs):  # type: ignore[no-untyped-def]
            self.updated += 1
            return update(*args, **kwargs)

        self.map.field = counted_field  # type: ignore[method-assign]
        self.map.update = counted_update  # type: ignore[method-assign]


def test_a_refinement_needs_finer_cells_than_the_map_s_and_loop_closure() -> None:
    half = SETTINGS.resolution_m / 2
    assert isinstance(FineRefinement.of(SETTINGS, half), FineRefinement)
    no_loops = MapperSettings.defaults(loop_closure=False, keep_trajectory=True)
    assert FineRefinement.of(no_loops, half) is None
    assert FineRefinement.of(SETTINGS, SETTINGS.resolution_m) is None  # the map's own cells


def test_the_field_is_brought_up_to_date_between_moves_and_drawn_anew_after_one() -> None:
    refinement = _Counted(SETTINGS)
    keyframes: list[Keyframe] = []

    def step(pose: Pose2, keyframe: bool) -> Pose2:
        if keyframe:
            keyframes.append(Keyframe(float(len(keyframes)), pose, _scan(pose)))
            refinement.add(keyframes)
        points = voxel_downsample(_scan(pose).hits, SETTINGS.voxel_size_m)
        return refinement.refine(keyframes, points, pose)

    start = Pose2(-2.0, -1.0, 0.3)
    step(start, keyframe=True)
    assert (refinement.drawn, refinement.updated) == (1, 0)
    step(start, keyframe=False)  # nothing new: the same field
    assert (refinement.drawn, refinement.updated) == (1, 0)
    step(Pose2(-1.7, -1.0, 0.3), keyframe=True)  # a keyframe 0.3 m on: stamped in
    assert (refinement.drawn, refinement.updated) == (1, 1)
    step(Pose2(-2.0 + FIELD_MARGIN_M + 0.1, -1.0, 0.3), keyframe=True)  # moved on: anew
    assert (refinement.drawn, refinement.updated) == (2, 1)
    refinement.clear()  # as after a re-solve: the fine map is drawn anew, and so the field
    step(Pose2(-0.8, -1.0, 0.3), keyframe=False)
    assert (refinement.drawn, refinement.updated) == (3, 1)


def test_a_refined_pose_stays_within_a_map_cell_of_the_match_and_nears_the_truth() -> None:
    refinement = FineRefinement(SETTINGS, SETTINGS.resolution_m / 2)
    truth = Pose2(0.5, -1.2, 0.4)
    keyframes = [Keyframe(0.0, truth, _scan(truth))]
    refinement.add(keyframes)
    points = voxel_downsample(_scan(truth).hits, SETTINGS.voxel_size_m)
    start = Pose2(truth.x + 0.03, truth.y - 0.02, truth.yaw)
    refined = refinement.refine(keyframes, points, start)
    assert math.hypot(refined.x - start.x, refined.y - start.y) <= 1.5 * SETTINGS.resolution_m
    assert math.hypot(refined.x - truth.x, refined.y - truth.y) < math.hypot(0.03, 0.02)
    assert np.isfinite([refined.x, refined.y, refined.yaw]).all()


def test_a_finished_mapper_lets_go_of_its_fine_map_and_still_matches_a_scan() -> None:
    mapper = ScanMapper(SETTINGS, fine=FineRefinement.of(SETTINGS, SETTINGS.resolution_m / 2))
    poses = [Pose2(0.1 * k, 0.0, 0.0) for k in range(6)]
    for k, pose in enumerate(poses):
        mapper.add(0.1 * k, _scan(pose), pose)
    assert mapper.fine is not None
    cells = mapper.grid.shape
    mapper.finish()
    assert mapper.fine is None
    assert mapper.grid.shape == cells  # the map itself is kept for writing out
    last = Pose2(0.65, 0.0, 0.0)
    result = mapper.add(0.6, _scan(last), last)
    assert math.hypot(result.pose.x - last.x, result.pose.y - last.y) < 0.05
