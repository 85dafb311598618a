"""Seeded perturbations of a laser log: each does what it says, the same way every time."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest

from navd.geometry import Pose2
from navd.offline.logfiles import LogScan
from navd.offline.perturb import perturb


def _log(n: int = 1000, rate_hz: float = 10.0) -> list[LogScan]:
    """A robot driving straight along x at 0.5 m/s, 181 beams, ranges 1..12 m."""
    ranges = np.linspace(1.0, 12.0, 181)
    return [
        LogScan(
            stamp=100.0 + i / rate_hz,
            angle_min=-math.pi / 2,
            angle_increment=math.pi / 180,
            range_min=0.1,
            range_max=30.0,
            ranges=ranges.copy(),
            odom=Pose2(0.5 * i / rate_hz, 0.0, 0.0),
        )
        for i in range(n)
    ]


def test_an_unknown_kind_is_refused_at_once_naming_the_known_ones() -> None:
    with pytest.raises(ValueError, match=r"'dorp'.*drop, every2, every3, odometry, "):
        perturb(_log(3), "dorp")
    with pytest.raises(ValueError, match=r"'spurius'.*joined by '\+'"):
        perturb(_log(3), "every2+spurius")


def test_drop_loses_a_tenth_of_the_scans_the_same_way_for_a_seed() -> None:
    log = _log()
    kept = [s.stamp for s in perturb(log, "drop", seed=1)]
    assert 870 <= len(kept) <= 930
    assert kept == [s.stamp for s in perturb(log, "drop", seed=1)]
    assert kept != [s.stamp for s in perturb(log, "drop", seed=2)]


def test_odometry_runs_five_percent_long_and_turns_two_degrees_a_minute() -> None:
    log = _log(601)  # 60 s, 30 m
    out = list(perturb(log, "odometry"))
    end = out[-1].odom
    assert end is not None
    assert end.yaw == pytest.approx(math.radians(2.0), rel=1e-6)
    assert math.hypot(end.x, end.y) == pytest.approx(30.0 * 1.05, rel=1e-3)
    # The drift turns the path: it bends toward +y, not just the heading.
    assert end.y > 0.3
    assert [s.stamp for s in out] == [s.stamp for s in log]


def test_noise_adds_three_centimetres_of_spread() -> None:
    log = _log(200)
    out = list(perturb(log, "noise", seed=3))
    diff = np.concatenate([o.ranges - s.ranges for o, s in zip(out, log, strict=True)])
    assert np.std(diff) == pytest.approx(0.03, rel=0.05)
    assert abs(np.mean(diff)) < 0.002


def test_half_beams_keeps_every_other_beam_over_the_same_arc() -> None:
    (scan,) = _log(1)
    (half,) = perturb([scan], "half_beams")
    np.testing.assert_array_equal(half.ranges, scan.ranges[::2])
    assert half.angle_increment == 2 * scan.angle_increment
    last = half.angle_min + half.angle_increment * (half.ranges.size - 1)
    assert last == pytest.approx(scan.angle_min + scan.angle_increment * (scan.ranges.size - 1))


def test_range8_turns_longer_readings_into_no_returns() -> None:
    (scan,) = _log(1)
    (short,) = perturb([scan], "range8")
    assert short.range_max == 8.0
    far = scan.ranges > 8.0
    assert np.isinf(short.ranges[far]).all()
    np.testing.assert_array_equal(short.ranges[~far], scan.ranges[~far])


def test_every2_and_every3_keep_one_scan_in_two_or_three() -> None:
    log = _log(10)
    assert [s.stamp for s in perturb(log, "every2")] == [log[i].stamp for i in (0, 2, 4, 6, 8)]
    assert [s.stamp for s in perturb(log, "every3")] == [log[i].stamp for i in (0, 3, 6, 9)]


def test_odometry_spikes_jump_one_step_in_a_hundred_and_keep_the_jump() -> None:
    log = _log(5001)  # 0.05 m a step along x
    out = list(perturb(log, "odometry_spikes", seed=4))
    steps = []
    for a, b in itertools.pairwise(out):
        assert a.odom is not None and b.odom is not None
        steps.append(a.odom.between(b.odom))
    spikes = [s for s in steps if abs(s.y) > 0.5 or abs(s.yaw) > 0.5]
    assert 30 <= len(spikes) <= 70  # 1 % of 5000
    assert all(abs(abs(s.y) - 1.0) < 1e-9 or abs(abs(s.yaw) - 1.5) < 1e-9 for s in spikes)
    assert {s.y > 0.5 for s in spikes if abs(s.y) > 0.5} == {True, False}  # either side
    # Every other step is the log's own: 0.05 m straight ahead in the robot's frame.
    calm = [s for s in steps if abs(s.y) <= 0.5 and abs(s.yaw) <= 0.5]
    assert all(abs(s.x - 0.05) < 1e-9 and abs(s.y) < 1e-9 for s in calm)
    # The jumps stay: the end is far from the log's.
    end, true_end = out[-1].odom, log[-1].odom
    assert end is not None and true_end is not None
    assert math.hypot(end.x - true_end.x, end.y - true_end.y) > 1.0


def test_fov120_keeps_the_front_third_of_a_full_turn_wherever_the_scan_starts() -> None:
    for start in (-math.pi, 0.0):  # the front in the middle, or at both ends
        scan = LogScan(
            stamp=1.0,
            angle_min=start,
            angle_increment=math.radians(1.0),
            range_min=0.1,
            range_max=30.0,
            ranges=np.arange(360, dtype=np.float64),
            odom=None,
        )
        (front,) = perturb([scan], "fov120")
        angles = front.angle_min + front.angle_increment * np.arange(front.ranges.size)
        assert front.ranges.size == 121
        assert angles[0] == pytest.approx(math.radians(-60.0))
        assert angles[-1] == pytest.approx(math.radians(60.0))
        # each beam keeps its reading: reading k was taken at start + k degrees
        taken_at = start + np.radians(front.ranges)
        np.testing.assert_allclose(np.cos(taken_at), np.cos(angles), atol=1e-9)
        np.testing.assert_allclose(np.sin(taken_at), np.sin(angles), atol=1e-9)


def test_fov120_leaves_a_narrower_lidar_whole() -> None:
    (scan,) = _log(1)  # 180 degrees
    narrow = dataclasses.replace(scan, angle_min=-0.5, ranges=scan.ranges[:58].copy())
    (same,) = perturb([narrow], "fov120")
    assert same is narrow


def test_spurious_puts_three_percent_of_readings_at_80_m_and_keeps_them_valid() -> None:
    log = _log(300)
    out = list(perturb(log, "spurious", seed=5))
    changed = np.concatenate([o.ranges != s.ranges for o, s in zip(out, log, strict=True)])
    assert changed.mean() == pytest.approx(0.03, abs=0.004)
    readings = np.concatenate([o.ranges for o in out])
    assert set(np.unique(readings[changed])) == {80.0}
    assert all(o.range_max > 80.0 for o in out)


def test_kinds_combine_left_to_right_the_same_way_for_a_seed() -> None:
    log = _log(600)
    out = list(perturb(log, "every3+spurious+odometry_spikes", seed=7))
    assert [s.stamp for s in out] == [log[i].stamp for i in range(0, 600, 3)]
    again = list(perturb(log, "every3+spurious+odometry_spikes", seed=7))
    for a, b in zip(out, again, strict=True):
        np.testing.assert_array_equal(a.ranges, b.ranges)
        assert a.odom == b.odom
    assert any(np.any(o.ranges == 80.0) for o in out)
