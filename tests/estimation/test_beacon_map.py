"""Beacon places learnt from bearings (seed 004's Kalman filter per beacon): seeded drives
with noisy bearings and a noisy robot pose; the places converge, their stated uncertainty
holds the error, a bad bearing is refused, and a range with a bearing places at once."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.estimation.beacon_map import BeaconMap, RobotPose

BEACONS = {"post": (6.0, 4.0), "door": (-3.0, 7.5), "tree": (2.0, -5.0), "far": (14.0, 2.0)}
POSE_STD_M, YAW_STD_RAD, BEARING_STD_RAD = 0.05, 0.02, 0.03


def _drive(seed: int, steps: int = 400) -> tuple[BeaconMap, np.random.Generator]:
    """A robot going round a 4 m circle once, taking a bearing to each beacon every step
    from a pose estimate that is itself off by the stated noise."""
    rng = np.random.default_rng(seed)
    learnt = BeaconMap(gate_chi2=10.8)
    cov = np.diag([POSE_STD_M**2, POSE_STD_M**2, YAW_STD_RAD**2])
    for k in range(steps):
        a = 2.0 * math.pi * k / steps
        x, y, yaw = 4.0 * math.cos(a), 4.0 * math.sin(a), a + math.pi / 2
        believed = RobotPose(
            x + rng.normal(0.0, POSE_STD_M),
            y + rng.normal(0.0, POSE_STD_M),
            yaw + rng.normal(0.0, YAW_STD_RAD),
            cov,
        )
        for beacon, (bx, by) in BEACONS.items():
            bearing = math.atan2(by - y, bx - x) - yaw + rng.normal(0.0, BEARING_STD_RAD)
            learnt.observe(
                beacon,
                believed,
                bearing_rad=math.remainder(bearing, math.tau),
                bearing_std_rad=BEARING_STD_RAD,
            )
    return learnt, rng


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_places_learnt_from_bearings_converge_within_20_cm(seed: int) -> None:
    learnt, _ = _drive(seed)
    for beacon, truth in BEACONS.items():
        place = learnt.beacons[beacon]
        assert place.mean is not None, beacon
        error = math.dist(truth, place.mean)
        assert error <= 0.2, f"{beacon}: {error:.3f} m off"
        # the filter knows how well it knows: the error is within 3 of its sigmas, and the
        # far beacon, seen across a narrow angle, is the least certain
        assert error <= 3.0 * place.std_m + 1e-3, (beacon, error, place.std_m)
    assert learnt.beacons["far"].std_m == max(b.std_m for b in learnt.beacons.values())


def test_one_bearing_does_not_place_a_beacon_and_crossing_rays_do() -> None:
    learnt = BeaconMap(gate_chi2=10.8)
    cov = np.diag([1e-4, 1e-4, 1e-6])
    assert not learnt.observe("b", RobotPose(0.0, 0.0, 0.0, cov), bearing_rad=math.pi / 4)
    assert learnt.beacons["b"].mean is None and learnt.revision == 0
    # a few centimetres sideways: the rays barely cross, still not placed
    assert not learnt.observe("b", RobotPose(0.05, 0.0, 0.0, cov), bearing_rad=math.pi / 4)
    # from (2, 0) the beacon at (2, 2) is straight ahead-left: now the rays cross there
    assert learnt.observe("b", RobotPose(2.0, 0.0, 0.0, cov), bearing_rad=math.pi / 2)
    place = learnt.beacons["b"]
    assert place.mean is not None
    assert place.mean == pytest.approx([2.0, 2.0], abs=0.05)


def test_a_bearing_far_from_the_place_is_refused() -> None:
    learnt, _ = _drive(0)
    before = learnt.beacons["post"]
    mean = None if before.mean is None else before.mean.copy()
    cov = np.diag([1e-4, 1e-4, 1e-6])
    # from the origin the post is at atan2(4, 6) = 34 deg: a bearing of 124 deg is a reflection
    changed = learnt.observe(
        "post", RobotPose(0.0, 0.0, 0.0, cov), bearing_rad=math.radians(124.0), bearing_std_rad=0.03
    )
    assert not changed and learnt.beacons["post"].refused >= 1
    assert mean is not None and learnt.beacons["post"].mean == pytest.approx(mean)


def test_a_range_with_a_bearing_places_a_beacon_at_once_with_the_poses_uncertainty() -> None:
    learnt = BeaconMap(gate_chi2=10.8)
    sure = RobotPose(1.0, 1.0, math.pi / 2, np.diag([1e-6, 1e-6, 1e-8]))
    assert learnt.observe(
        "b", sure, range_m=3.0, range_std_m=0.05, bearing_rad=-math.pi / 2, bearing_std_rad=0.01
    )
    place = learnt.beacons["b"]
    assert place.mean == pytest.approx([4.0, 1.0])
    unsure = RobotPose(1.0, 1.0, math.pi / 2, np.diag([0.25, 0.25, 0.01]))
    other = BeaconMap(gate_chi2=10.8)
    other.observe(
        "b", unsure, range_m=3.0, range_std_m=0.05, bearing_rad=-math.pi / 2, bearing_std_rad=0.01
    )
    assert other.beacons["b"].std_m > 5 * place.std_m
    # a range alone never places one
    assert not BeaconMap(10.8).observe("c", sure, range_m=2.0)


def test_a_beacon_that_moved_is_learnt_again_where_it_now_stands() -> None:
    learnt = BeaconMap(gate_chi2=10.8)
    cov = np.diag([1e-4, 1e-4, 1e-6])
    rng = np.random.default_rng(5)

    def look(at: tuple[float, float], steps: int) -> None:
        for k in range(steps):
            x, y = -2.0 + 4.0 * k / steps, 0.0  # back and forth along a 4 m line
            bearing = math.atan2(at[1] - y, at[0] - x) + rng.normal(0.0, 0.01)
            learnt.observe(
                "b", RobotPose(x, y, 0.0, cov), bearing_rad=bearing, bearing_std_rad=0.01
            )

    look((1.0, 3.0), 100)
    first = learnt.beacons["b"].mean
    assert first is not None and math.dist(first, (1.0, 3.0)) < 0.05
    look((-1.5, 5.0), 200)  # carried elsewhere
    place = learnt.beacons["b"]
    assert place.mean is not None and math.dist(place.mean, (-1.5, 5.0)) < 0.1
    assert place.refused >= 20
