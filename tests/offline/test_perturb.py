"""Seeded perturbations of a laser log: each does what it says, the same way every time."""

from __future__ import annotations

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
    with pytest.raises(ValueError, match=r"'dorp'.*drop, odometry, noise, half_beams, range8"):
        perturb(_log(3), "dorp")


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
