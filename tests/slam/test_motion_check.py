"""Plausible steps between scans: the limits, the replay's list of jumps, and the tracker
that neither follows an odometry spike nor takes a match that jumps."""

from __future__ import annotations

import dataclasses
import math

import pytest

from navd.geometry import Pose2
from navd.slam import MapperSettings, MotionLimits, ScanMapper, jumps
from navd.slam.motion_check import MIN_STEP_S, MotionCheck
from tests.slam.test_mapper import SENSOR_RANGE_M, front_scan, room_scan

LIMITS = MotionLimits(speed_mps=2.5, turn_radps=3.0)


@pytest.mark.parametrize(
    ("step", "dt_s", "allowed"),
    [
        (Pose2(0.5, 0.0, 0.0), 0.2, True),  # 2.5 m/s
        (Pose2(0.3, 0.42, 0.0), 0.2, False),  # 0.52 m
        (Pose2(0.0, 0.0, 0.6), 0.2, True),  # 3 rad/s
        (Pose2(0.0, 0.0, -0.65), 0.2, False),
        (Pose2(0.0, 0.0, 2 * math.pi - 0.1), 0.2, True),  # a turn of -0.1 rad, wrapped
        # steps stamped closer than MIN_STEP_S are judged over MIN_STEP_S
        (Pose2(0.45, 0.0, 0.0), 0.001, True),
        (Pose2(0.9, 0.0, 0.0), 0.3, False),
        (Pose2(0.9, 0.0, 0.0), 0.4, True),
    ],
)
def test_a_step_is_plausible_within_speed_and_turn_over_its_time(
    step: Pose2, dt_s: float, allowed: bool
) -> None:
    assert MIN_STEP_S == 0.2
    assert LIMITS.allows(step, dt_s) is allowed


def test_jumps_lists_each_step_beyond_the_limits_with_when_and_how_far() -> None:
    stamps = [10.0 + 0.2 * i for i in range(6)]
    poses = [Pose2(0.1 * i, 0.0, 0.0) for i in range(6)]
    poses[3] = Pose2(0.3, 0.8, 0.0)  # out 0.8 m sideways and back: two jumps
    poses[5] = Pose2(0.5, 0.0, math.radians(80))  # a sudden 80 degree turn
    found = jumps(stamps, poses, LIMITS)
    assert [j.index for j in found] == [3, 4, 5]
    assert found[0].offset_s == pytest.approx(0.6)
    assert found[0].distance_m == pytest.approx(math.hypot(0.1, 0.8))
    assert found[2].turn_deg == pytest.approx(80.0)


def test_the_check_coasts_on_the_last_step_and_forgets_when_told() -> None:
    check = MotionCheck(LIMITS)
    assert check.coasted() is None and check.plausible(0.0, Pose2(99.0, 0.0, 0.0))
    check.record(0.0, Pose2(0.0, 0.0, 0.0))
    check.record(0.2, Pose2(0.2, 0.0, 0.1))
    coasted = check.coasted()
    assert coasted is not None
    expected = Pose2(0.2, 0.0, 0.1).compose(Pose2(0.2, 0.0, 0.1))
    assert (coasted.x, coasted.y, coasted.yaw) == pytest.approx(tuple(expected))
    assert not check.plausible(0.4, Pose2(1.5, 0.0, 0.0))
    check.moved_to(Pose2(1.2, 0.0, 0.0))  # a loop closure moved the robot: no step of its own
    assert check.plausible(0.4, Pose2(1.5, 0.0, 0.0))
    check.forget()  # a pose set from outside
    assert check.coasted() is None and check.plausible(0.4, Pose2(50.0, 0.0, 0.0))


def _drive() -> tuple[ScanMapper, list[Pose2]]:
    """A drive along the bench room at 0.5 m/s, 5 scans a second."""
    mapper = ScanMapper(MapperSettings.defaults(keep_trajectory=True))
    truth = [Pose2(-4.0 + 0.1 * i, -1.0 + 0.01 * i, 0.005 * i) for i in range(70)]
    return mapper, truth


def _corridor_errors(limits: MotionLimits) -> tuple[ScanMapper, list[float]]:
    """Down the corridor at 0.5 m/s, 5 scans a second, the odometry jumping 1 m ahead (5 m/s)
    at scan 30 and keeping the jump: each pose's distance from the truth."""
    settings = MapperSettings.defaults(keep_trajectory=True, max_range_m=SENSOR_RANGE_M)
    mapper = ScanMapper(dataclasses.replace(settings, motion_limits=limits))
    truth = [Pose2(0.1 * i, 0.0, 0.0) for i in range(60)]
    for i, pose in enumerate(truth):
        odom = Pose2(1.0, 0.0, 0.0).compose(pose) if i >= 30 else pose
        mapper.add(0.2 * i, front_scan(pose), odom)
    poses = mapper.trajectory()
    return mapper, [math.hypot(p.x - t.x, p.y - t.y) for p, t in zip(poses, truth, strict=True)]


def test_an_odometry_spike_down_a_corridor_is_not_followed() -> None:
    # A corridor's walls say nothing of how far along it the robot is: a spike along it
    # fits the map as well as the truth, and nothing would repair it.
    mapper, errors = _corridor_errors(LIMITS)
    assert mapper.counts.odometry_spikes == 1
    assert max(errors) < 0.25  # (0.16 m measured: coasting on the last step)
    followed, errors = _corridor_errors(MotionLimits(1000.0, 1000.0))  # no limits
    assert followed.counts.odometry_spikes == 0
    assert max(errors[30:]) > 0.8  # (0.95 m measured)


def test_a_match_is_refused_only_as_a_clear_jump_from_a_plausible_prior() -> None:
    check = MotionCheck(LIMITS)
    check.record(0.0, Pose2(0.0, 0.0, 0.0))
    check.record(0.2, Pose2(0.1, 0.0, 0.0))  # the scan period: 0.2 s
    prior = Pose2(0.5, 0.0, 0.0)  # 0.4 m on: plausible (0.5 m in 0.2 s)
    assert check.jumped(0.21, prior, Pose2(1.15, 0.0, 0.0))  # 1.05 m: beyond twice the limit
    assert not check.jumped(0.21, prior, Pose2(1.0, 0.0, 0.0))  # 0.9 m: only just beyond
    assert check.jumped(0.21, prior, Pose2(0.1, 0.0, 1.3))  # a 1.3 rad turn (twice: 1.2)
    assert not check.jumped(0.21, Pose2(1.5, 0.0, 0.0), Pose2(1.6, 0.0, 0.0))  # (a chosen prior)


def test_a_match_just_beyond_the_limits_stands() -> None:
    # Scans 0.1 m and 0.2 s apart; then one stamped 0.05 s after the last whose scan was
    # taken 0.75 m on while the wheels say 0.45 m. The match finds it 0.75 m on: beyond the
    # limits (0.5 m a scan period) but not twice beyond; refusing such matches cost more than
    # it saved on the robustness suite. Where the scan fits is taken.
    mapper, truth = _drive()
    for i, pose in enumerate(truth[:20]):
        mapper.add(0.2 * i, room_scan(pose), pose)
    last = truth[19]
    seen = last.compose(Pose2(0.75, 0.0, 0.0))
    result = mapper.add(0.2 * 19 + 0.05, room_scan(seen), last.compose(Pose2(0.45, 0.0, 0.0)))
    assert mapper.counts.implausible == 0 and result.matched
    assert math.hypot(result.pose.x - seen.x, result.pose.y - seen.y) < 0.05


def test_an_implausible_odometry_step_the_scan_confirms_is_followed() -> None:
    # A log whose stamps lie (intel's, after a logging stall): the robot moved 0.8 m between
    # two scans stamped 10 ms apart, and the wheels say so. The scan fits far better where
    # the wheels put it than one step on: it is no spike.
    mapper, truth = _drive()
    stamps = [0.2 * i if i < 30 else 0.2 * i - 0.19 for i in range(len(truth))]
    truth = [p if i < 30 else p.compose(Pose2(0.7, 0.0, 0.0)) for i, p in enumerate(truth)]
    for stamp, pose in zip(stamps, truth, strict=True):
        mapper.add(stamp, room_scan(pose), pose)
    assert mapper.counts.odometry_spikes == 0 and mapper.counts.implausible == 0
    for pose, true in zip(mapper.trajectory(), truth, strict=True):
        assert math.hypot(pose.x - true.x, pose.y - true.y) < 0.06
    (jump,) = jumps(stamps, mapper.trajectory(), LIMITS)  # still reported: the stamps lie
    assert jump.index == 30
