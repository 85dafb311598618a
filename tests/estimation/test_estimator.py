"""The estimator on synthetic drives with known truth (seeded noise), and its GPS/datum rules."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest

from navd.bench.motion_scenario import FigureEight, SensorSuite, SpinInPlace, drive, replay
from navd.config import NavdConfig, apply_changes
from navd.estimation.estimator import Localization, StateEstimator
from navd.estimation.settings import EstimatorSettings
from navd.geometry import rotation_rpy
from navd.lifecycle.messages import (
    BeaconObservation,
    CompassHeading,
    GpsFix,
    Imu,
    InitialPose,
    PoseEstimate,
    PoseMeasurement,
    Vector3,
)

PATH = FigureEight()
DATUM = {"world.datum_latitude_deg": 52.52, "world.datum_longitude_deg": 13.405}


def _config(**changes: object) -> NavdConfig:
    config, _ = apply_changes(NavdConfig(), changes)
    return config


def _position_rmse(estimates: list[PoseEstimate], after_s: float = 5.0) -> float:
    errors = [
        (e.x_m - PATH.at(e.stamp).x) ** 2 + (e.y_m - PATH.at(e.stamp).y) ** 2
        for e in estimates
        if e.stamp >= after_s
    ]
    return math.sqrt(float(np.mean(errors)))


def test_lidar_and_imu_track_a_figure_eight_within_3_cm() -> None:
    estimator = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    estimates = replay(estimator, drive(PATH, SensorSuite(), 60.0))
    assert _position_rmse(estimates) <= 0.03
    assert estimator.counters["resets"] == 0


def test_gps_imu_and_compass_beat_the_raw_gps_by_far() -> None:
    messages = drive(PATH, SensorSuite(lidar_hz=0, gps_hz=5, compass_hz=10), 60.0)
    estimator = StateEstimator(EstimatorSettings.from_config(_config(**DATUM)))
    estimates = replay(estimator, messages)
    assert estimator.geo is not None
    raw = [
        estimator.geo.to_map(m.latitude_deg, m.longitude_deg)
        for m in messages
        if isinstance(m, GpsFix) and m.stamp >= 5.0
    ]
    truth = [PATH.at(m.stamp) for m in messages if isinstance(m, GpsFix) and m.stamp >= 5.0]
    raw_rmse = math.sqrt(
        float(
            np.mean([(x - t.x) ** 2 + (y - t.y) ** 2 for (x, y), t in zip(raw, truth, strict=True)])
        )
    )
    fused = _position_rmse(estimates)
    assert fused <= 0.8
    assert fused <= 0.5 * raw_rmse


def test_outdoor_indoor_outdoor_switches_without_jumps_beyond_3_sigma() -> None:
    suite = SensorSuite(gps_hz=5, compass_hz=10)
    messages = drive(
        PATH,
        suite,
        60.0,
        gps_windows=[(0.0, 20.0), (40.0, 60.0)],
        lidar_windows=[(20.0, 40.0)],
    )
    estimates = replay(StateEstimator(EstimatorSettings.from_config(_config(**DATUM))), messages)
    jumps = []
    for before, after in itertools.pairwise(estimates):
        if before.stamp < 1.0:
            continue
        t0, t1 = PATH.at(before.stamp), PATH.at(after.stamp)
        moved = np.array([after.x_m - before.x_m, after.y_m - before.y_m])
        jump = float(np.linalg.norm(moved - [t1.x - t0.x, t1.y - t0.y]))
        sigma = math.sqrt(float(np.linalg.eigvalsh(before.covariance[:2, :2])[-1]))
        jumps.append(jump / sigma)
    assert max(jumps) <= 3.0
    indoors = [e for e in estimates if 25.0 <= e.stamp < 40.0]
    assert _position_rmse(indoors, after_s=25.0) <= 0.05


def test_lidar_poses_80_ms_late_give_the_in_order_result() -> None:
    on_time = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    late = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    replay(on_time, drive(PATH, SensorSuite(wheel_hz=50), 20.0))
    replay(late, drive(PATH, SensorSuite(wheel_hz=50, lidar_delay_s=0.08), 20.0))
    a, b = on_time.history.latest, late.history.latest
    assert a.stamp == b.stamp
    assert math.hypot(a.x[0] - b.x[0], a.x[1] - b.x[1]) < 1e-3
    assert abs(a.x[6] - b.x[6]) < math.radians(0.1)
    assert late.counters["late_events"] > 150


def _fix(t: float, lat: float, lon: float, accuracy: float = 1.0) -> GpsFix:
    return GpsFix(
        stamp=t,
        received=t,
        device_id="gps",
        latitude_deg=lat,
        longitude_deg=lon,
        altitude_m=0.0,
        horizontal_accuracy_m=accuracy,
    )


def _pose(t: float, x: float, y: float, yaw: float = 0.0) -> PoseMeasurement:
    return PoseMeasurement(
        stamp=t,
        received=t,
        source="lidar",
        x_m=x,
        y_m=y,
        yaw_rad=yaw,
        covariance=np.diag([1e-4, 1e-4, 1e-4]),
    )


def test_no_fix_is_used_before_a_good_fix_sets_the_datum() -> None:
    estimator = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    assert estimator.add_gps(_fix(0.0, 52.52, 13.405, accuracy=20.0), 0.0) is None
    assert estimator.geo is None
    assert estimator.estimate(0.0) is None
    assert estimator.counters["ignored"] == {"gps_before_datum": 1}
    estimator.add_gps(_fix(0.2, 52.52, 13.405, accuracy=2.0), 0.2)
    assert estimator.geo is not None
    estimate = estimator.estimate(0.2)
    assert estimate is not None
    assert (estimate.x_m, estimate.y_m) == pytest.approx((0.0, 0.0))


def test_a_datum_taken_while_localized_keeps_the_robot_where_it_is() -> None:
    estimator = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    estimator.add_pose(_pose(0.0, 3.0, 4.0), 0.0)
    estimator.add_gps(_fix(0.1, 48.1, 11.5), 0.1)
    estimate = estimator.estimate(0.1)
    assert estimate is not None
    assert (estimate.x_m, estimate.y_m) == pytest.approx((3.0, 4.0), abs=1e-3)
    assert estimator.geo is not None
    assert estimator.geo.to_map(48.1, 11.5) == pytest.approx((3.0, 4.0), abs=1e-6)


def test_stale_and_far_fixes_are_ignored_and_counted() -> None:
    estimator = StateEstimator(EstimatorSettings.from_config(_config(**DATUM)))
    estimator.add_pose(_pose(0.0, 0.0, 0.0), 0.0)
    assert estimator.add_gps(_fix(0.0, 52.52, 13.405), 5.0) is None
    assert estimator.add_gps(_fix(5.0, 53.0, 13.405), 5.0) is None
    assert estimator.counters["ignored"] == {"gps_stale": 1, "gps_off_map": 1}


def test_compass_before_the_first_fix_sets_the_starting_yaw() -> None:
    estimator = StateEstimator(EstimatorSettings.from_config(_config(**DATUM)))
    compass = CompassHeading(
        stamp=0.0, received=0.0, device_id="c", bearing_deg=0.0, accuracy_deg=2.0, true_north=True
    )
    estimator.add_compass(compass, 0.0)
    estimator.add_gps(_fix(0.1, 52.52, 13.405), 0.1)
    estimate = estimator.estimate(0.1)
    assert estimate is not None
    assert estimator.geo is not None
    # Facing true north: map yaw is pi/2 less the grid convergence.
    assert estimate.yaw_rad == pytest.approx(math.pi / 2 - estimator.geo.grid_convergence_rad)


def test_localization_degrades_then_is_lost_without_position_updates() -> None:
    estimator = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    assert estimator.localization(estimator.estimate(0.0))[0] == Localization.UNINITIALIZED
    estimator.set_pose(
        InitialPose(stamp=0.0, received=0.0, x_m=1.0, y_m=2.0, yaw_rad=0.5, std_xy_m=0.05)
    )
    sweep = [estimator.localization(estimator.estimate(0.05 * i)) for i in range(100)]
    states = [state for state, _, _ in sweep]
    changes = [s for i, s in enumerate(states) if i == 0 or s != states[i - 1]]
    assert changes == [Localization.OK, Localization.DEGRADED, Localization.LOST]
    stds = [std for _, std, _ in sweep]
    assert stds == sorted(stds)  # predict-only: the position only gets less certain


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_position_spread_that_is_not_a_number_is_lost_not_ok(bad: float) -> None:
    estimator = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    estimator.set_pose(
        InitialPose(stamp=0.0, received=0.0, x_m=1.0, y_m=2.0, yaw_rad=0.5, std_xy_m=0.05)
    )
    good = estimator.estimate(0.0)
    assert good is not None and estimator.localization(good)[0] == Localization.OK
    cov = good.covariance.copy()
    cov[0, 0] = bad
    state, std, _ = estimator.localization(dataclasses.replace(good, covariance=cov))
    assert state == Localization.LOST and not std <= 1.0


def _mounted(**mounts: object) -> NavdConfig:
    """The config with the datum and these ``mounts`` tables."""
    world = {key.split(".")[1]: value for key, value in DATUM.items()}
    return NavdConfig.model_validate({"world": world, "mounts": mounts})


def _spin_spread(antenna_config: dict[str, object] | None) -> float:
    """[m] farthest the estimate strays from the true centre of a robot turning on the spot
    with a GNSS antenna 0.3 m ahead of its centre (RTK-grade fixes, IMU and compass)."""
    suite = SensorSuite(
        imu_hz=200, lidar_hz=0, gps_hz=5, gps_std_m=0.02, compass_hz=10, gps_antenna_m=(0.3, 0.0)
    )
    messages = drive(SpinInPlace(0.6), suite, 40.0)
    estimator = StateEstimator(EstimatorSettings.from_config(_mounted(gps=antenna_config or {})))
    estimates = [e for e in replay(estimator, messages) if e.stamp >= 10.0]
    return max(math.hypot(e.x_m, e.y_m) for e in estimates)


def test_a_gnss_antenna_ahead_of_the_centre_no_longer_moves_a_robot_turning_in_place() -> None:
    unmounted = _spin_spread(None)  # the fix is taken for the centre: the estimate circles
    mounted = _spin_spread({"gps": {"x_m": 0.3, "y_m": 0.0}})  # the drive's receiver id
    assert unmounted >= 0.2
    assert mounted <= 0.08


def test_a_compass_turned_on_its_mount_gives_the_robots_heading() -> None:
    # The compass's forward axis points 90° to the robot's left: it reads the robot's
    # bearing minus 90°. With the mount the estimate's heading is the robot's.
    turned = SensorSuite(lidar_hz=0, gps_hz=5, compass_hz=10)
    messages = [
        dataclasses.replace(m, bearing_deg=(m.bearing_deg - 90.0) % 360.0)
        if isinstance(m, CompassHeading)
        else m
        for m in drive(PATH, turned, 30.0)
    ]
    # the drive's compass has the id "compass"
    config = _mounted(compasses={"compass": {"yaw_rad": math.pi / 2}})
    estimates = replay(StateEstimator(EstimatorSettings.from_config(config)), messages)
    errors = [
        abs(math.remainder(e.yaw_rad - PATH.at(e.stamp).yaw, 2 * math.pi))
        for e in estimates
        if e.stamp >= 10.0
    ]
    assert max(errors) < math.radians(10)


def test_a_dual_antenna_heading_comes_through_the_receivers_baseline_mount() -> None:
    # The receiver's second antenna sits to the robot's left: its HDT heading is the
    # robot's bearing minus 90°, and it comes under the receiver's own id ("gps").
    suite = SensorSuite(lidar_hz=0, gps_hz=5, compass_hz=10)
    messages = [
        dataclasses.replace(m, device_id="gps", bearing_deg=(m.bearing_deg - 90.0) % 360.0)
        if isinstance(m, CompassHeading)
        else m
        for m in drive(PATH, suite, 30.0)
    ]
    config = _mounted(gps={"gps": {"heading_yaw_rad": math.pi / 2}})
    estimates = replay(StateEstimator(EstimatorSettings.from_config(config)), messages)
    errors = [
        abs(math.remainder(e.yaw_rad - PATH.at(e.stamp).yaw, 2 * math.pi))
        for e in estimates
        if e.stamp >= 10.0
    ]
    assert max(errors) < math.radians(10)


def test_an_imu_mounted_sideways_and_upside_down_is_turned_into_base_link() -> None:
    # The same drive with the IMU rolled half a turn and yawed 90°: what the filter is fed
    # must match what an aligned IMU gives.
    rpy = (math.pi, 0.0, math.pi / 2)
    rotation = rotation_rpy(*rpy)
    aligned = [m for m in drive(PATH, SensorSuite(lidar_hz=0), 2.0) if isinstance(m, Imu)][:50]
    mounted = [
        dataclasses.replace(
            m,
            gyro_radps=Vector3(*(rotation.T @ np.array(m.gyro_radps))),
            accel_mps2=Vector3(*(rotation.T @ np.array(m.accel_mps2))),
        )
        for m in aligned
    ]
    roll, pitch, yaw = rpy
    mounts = {"imu": {"roll_rad": roll, "pitch_rad": pitch, "yaw_rad": yaw}}  # the drive's id
    plain = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    turned = StateEstimator(EstimatorSettings.from_config(_mounted(imus=mounts)))
    unmounted = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    for a, b in zip(aligned, mounted, strict=True):
        plain.add_imu(a)
        turned.add_imu(b)
        unmounted.add_imu(b)
    np.testing.assert_allclose(turned.madgwick.quaternion, plain.madgwick.quaternion, atol=1e-9)
    # without the mount the filter thinks the robot is upside down
    tilt = np.array(unmounted.madgwick.quaternion) - np.array(plain.madgwick.quaternion)
    assert np.abs(tilt).max() > 0.5


# --- beacons ----------------------------------------------------------------------------

ANCHORS = {"a1": (-7.0, -4.0), "a2": (7.0, -4.0), "a3": (7.0, 4.0), "a4": (-7.0, 4.0)}


def _anchored(**changes: object) -> EstimatorSettings:
    raw = NavdConfig().model_dump()
    raw["beacons"]["known"] = {b: {"x_m": x, "y_m": y} for b, (x, y) in ANCHORS.items()}
    config = NavdConfig.model_validate(raw)
    if changes:
        config, _ = apply_changes(config, changes)
    return EstimatorSettings.from_config(config)


def _ranges(duration_s: float, rate_hz: float, std_m: float, seed: int) -> list[BeaconObservation]:
    """UWB-like ranges to the anchors in turn along PATH, with Gaussian noise."""
    rng = np.random.default_rng(seed)
    names = list(ANCHORS)
    out = []
    for k in range(int(duration_s * rate_hz)):
        t = k / rate_hz
        truth = PATH.at(t)
        beacon = names[k % len(names)]
        bx, by = ANCHORS[beacon]
        distance = math.hypot(bx - truth.x, by - truth.y) + rng.normal(0.0, std_m)
        out.append(
            BeaconObservation(
                stamp=t,
                received=t + 0.01,
                device_id="uwb",
                beacon_id=beacon,
                range_m=distance,
                range_std_m=std_m,
            )
        )
    return out


def test_ranges_to_four_known_beacons_start_and_hold_the_estimate_without_lidar() -> None:
    suite = SensorSuite(lidar_hz=0, compass_hz=10)
    messages = sorted(
        [*drive(PATH, suite, 60.0), *_ranges(60.0, 20.0, 0.1, seed=3)], key=lambda m: m.received
    )
    estimator = StateEstimator(_anchored())
    estimates = replay(estimator, messages)
    # it started by itself, from the first three ranges, near the truth
    first = estimates[0]
    assert math.dist((first.x_m, first.y_m), (PATH.at(first.stamp).x, PATH.at(first.stamp).y)) < 0.5
    errors = [
        math.dist((e.x_m, e.y_m), (PATH.at(e.stamp).x, PATH.at(e.stamp).y))
        for e in estimates
        if e.stamp >= 5.0
    ]
    assert max(errors) <= 0.3
    assert estimator.counters["rejected"].get("beacon", 0) < 0.05 * 1200


def test_beacons_not_listed_are_learnt_only_when_learning_is_on() -> None:
    messages = [
        BeaconObservation(
            stamp=1.0, received=1.0, device_id="cam", beacon_id="tag7", bearing_rad=0.3
        )
    ]
    quiet = StateEstimator(_anchored(**{"beacons.learn": False}))
    quiet.set_pose(InitialPose(stamp=0.5, received=0.5, x_m=0.0, y_m=0.0, yaw_rad=0.0))
    replay(quiet, messages)
    assert quiet.counters["ignored"] == {"beacon_unknown": 1}
    learning = StateEstimator(_anchored())
    replay(learning, messages)
    assert learning.counters["ignored"] == {"beacon_before_start": 1}  # no pose to learn from
    places = {p.beacon_id: p for p in learning.beacon_places()}
    assert set(places) == set(ANCHORS) and not any(p.learnt for p in places.values())


def test_a_reflected_range_is_left_out_of_the_start() -> None:
    estimator = StateEstimator(_anchored())
    truth = (1.0, -1.0)
    for k, (beacon, (bx, by)) in enumerate(ANCHORS.items()):
        distance = math.hypot(bx - truth[0], by - truth[1]) + (3.0 if beacon == "a2" else 0.0)
        seen = BeaconObservation(
            stamp=0.1 * k, received=0.1 * k, device_id="uwb", beacon_id=beacon,
            range_m=distance, range_std_m=0.1,
        )  # fmt: skip
        estimator.add_beacon(seen, 0.1 * k)
    started = estimator.estimate(0.4)
    assert started is not None  # from the three that agree, a2's 3 m too long left out
    assert math.dist((started.x_m, started.y_m), truth) < 0.05


def test_the_position_spread_is_the_largest_eigenvalue_of_the_position_block() -> None:
    from navd.estimation.localization import largest_eigenvalue

    rng = np.random.default_rng(4)
    blocks = [rng.normal(size=(2, 2)) for _ in range(200)]
    cases = [m @ m.T for m in blocks] + [np.zeros((2, 2)), np.diag([4.0, 4.0]), np.diag([0, 9.0])]
    for cov in cases:
        expected = np.linalg.eigvalsh(cov)[-1]
        got = largest_eigenvalue(cov[0, 0], cov[0, 1], cov[1, 1])
        assert got == pytest.approx(expected, rel=1e-12, abs=1e-15)
