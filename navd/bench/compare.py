"""navd beside the peer libraries that do the same jobs, timed in one run on the same inputs.

The peers are development dependencies (``pip install -e .[dev]``); a peer that is not
installed is reported as missing and its rows are left out. Ratios are navd's time over the
peer's: below 1, navd is faster. On a noisy machine the ratios, not the times, are the
figures of record.

- A* (pyastar2d): the grid the daemon plans on (5 cm cells, obstacles inflated with the
  default configuration), 400² and 2000², corner to corner; pyastar2d gets the same cells as
  weights 1 + w * cost (inf where blocked). The two search different metrics on it: pyastar2d
  charges a diagonal step the same as a straight one (its heuristic is the Chebyshev
  distance), navd charges it sqrt 2 (octile heuristic). Each route is priced in navd's metric
  to show what the difference buys. Uniform grids (free or blocked, 1000² and 2000²): the
  grid pyastar2d and most benchmarks use, where navd's search jumps.
- Madgwick (imufusion): one IMU message into the filter, as the daemon has it (an ``Imu``
  message with gyro [rad/s] and accel [m/s²] tuples): navd's ``MadgwickFilter.update`` takes
  it as it is; imufusion's ``Ahrs.update_no_magnetometer`` takes numpy arrays in deg/s and g,
  built from the message in the loop (the figure of record, "with the message included"),
  and also from arrays built beforehand (imufusion's best case, printed beside it); its sample
  period is set once (its API takes no time stamps). Both over the same 20 s of a
  figure-eight drive.
- UKF step (filterpy): predict + update of a lidar pose event (x, y, yaw with the IMU rows
  and the no-sliding row) over a 60 s drive: navd's ``PoseUkf.step`` (filterpy's algebra over
  all sigma points at once, with its measurement gate) against filterpy's own
  ``UnscentedKalmanFilter`` with the same model, sigma points, residuals and means, called
  as its documentation shows (its per-sigma-point loops).
- Scan registration (kiss-icp): a 720-ray scan of the synthetic room to a pose: navd's
  tracker (correlative match onto the map, keyframes, loop checks) against kiss-icp's
  registration of the same points (its local map, adaptive threshold, one thread); and
  navd's scan odometry (the same method as kiss-icp's, in the plane, with a yaw search
  before ICP) against kiss-icp on the same points, with how far each ended from the truth.
"""

from __future__ import annotations

import importlib.util
import math
import time
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from navd.bench import compare_scan
from navd.bench.motion_scenario import FigureEight, SensorSuite, drive
from navd.bench.planning import random_rectangles, uniform_costmap
from navd.bench.timing import median_ms, paired_ms
from navd.config import NavdConfig
from navd.estimation import EstimatorSettings, MadgwickFilter, Measurement, PoseUkf, UkfSettings
from navd.lifecycle import percentile
from navd.lifecycle.messages import Imu
from navd.planning import (
    SQRT2,
    Costmap,
    GlobalPlanner,
    GridFrame,
    PlannedPath,
    SearchSettings,
    build_costmap,
    costmap_settings,
)

if TYPE_CHECKING:
    pass

__all__ = ["PEERS", "run"]

FloatArray = npt.NDArray[np.float64]
PEERS = ("pyastar2d", "imufusion", "filterpy", "kiss_icp")
GRAVITY_MPS2 = 9.80665
SPACED_UKF_STEPS = 100  # steps timed one by one after a pause (a cold step, as in the daemon)
SPACED_UKF_PAUSE_S = 0.01


def _route_cost_m(costmap: Costmap, cells: npt.NDArray[np.integer[Any]], weight: float) -> float:
    """[m] a cell route priced in navd's metric: step length x (1 + w * mean cell cost)."""
    cost = costmap.cost[cells[:, 0], cells[:, 1]].astype(np.float64)
    steps = np.diff(cells, axis=0)
    lengths = np.where(np.all(steps != 0, axis=1), SQRT2, 1.0)
    total = float(np.sum(lengths * (1.0 + weight * 0.5 * (cost[:-1] + cost[1:]))))
    return total * costmap.frame.resolution_m


def _astar_weighted(cells: int, repeats: int) -> dict[str, object]:
    config = NavdConfig()
    weight = config.planning.cost_weight
    # Crops of one 2000² field, so both sizes have the same obstacles at the same scale.
    occupied = random_rectangles(2000, 0.25, seed=2000)[:cells, :cells].copy()
    occupied[:20, :20] = False
    occupied[-20:, -20:] = False
    frame = GridFrame(0.05, 0.0, 0.0, cells, cells)
    costmap = build_costmap(
        frame,
        occupied,
        np.zeros_like(occupied),
        costmap_settings(config.planning, config.robot, config.safety),
    )
    start, goal = (4, 4), (cells - 5, cells - 5)
    start_m, goal_m = tuple(frame.centers_of(np.array([start, goal])))
    search = SearchSettings(cost_weight=weight, smooth=False)
    planner = GlobalPlanner()

    def ours() -> object:
        planner.forget_last_route()  # a search every time: searches are compared, not reuse
        return planner.plan(costmap, tuple(start_m), tuple(goal_m), search)

    route = ours()
    assert isinstance(route, PlannedPath)
    figures: dict[str, object] = {
        f"astar_weighted_{cells}_navd_expanded": route.cells_expanded,
        f"astar_weighted_{cells}_navd_route_cost_m": round(route.cost, 3),
    }
    if importlib.util.find_spec("pyastar2d") is None:
        figures[f"astar_weighted_{cells}_navd_ms"] = round(median_ms(ours, repeats), 2)
        return figures
    import pyastar2d  # noqa: PLC0415 - a development dependency

    weights = np.where(np.isfinite(costmap.cost), 1.0 + weight * costmap.cost, np.inf)
    weights = weights.astype(np.float32)

    def peer() -> object:
        return pyastar2d.astar_path(weights, start, goal, allow_diagonal=True)

    navd_ms, peer_ms = paired_ms(ours, peer, repeats)
    path = pyastar2d.astar_path(weights, start, goal, allow_diagonal=True)
    figures.update(
        {
            f"astar_weighted_{cells}_navd_ms": round(navd_ms, 2),
            f"astar_weighted_{cells}_pyastar2d_ms": round(peer_ms, 2),
            f"astar_weighted_{cells}_pyastar2d_route_cost_m": round(
                _route_cost_m(costmap, path, weight), 3
            ),
            f"astar_weighted_{cells}_ratio": round(navd_ms / peer_ms, 3),
        }
    )
    return figures


def _astar_uniform(cells: int, repeats: int) -> dict[str, object]:
    costmap = uniform_costmap(cells)
    search = SearchSettings(cost_weight=0.0, smooth=False)
    start_m, goal_m = (5.5, 5.5), (cells - 5.5, cells - 5.5)
    planner = GlobalPlanner()

    def ours() -> object:
        planner.forget_last_route()
        return planner.plan(costmap, start_m, goal_m, search)

    if importlib.util.find_spec("pyastar2d") is None:
        return {f"astar_uniform_{cells}_navd_ms": round(median_ms(ours, repeats), 2)}
    import pyastar2d  # noqa: PLC0415

    weights = np.where(costmap.obstacles, np.inf, 1.0).astype(np.float32)
    start, goal = (5, 5), (cells - 6, cells - 6)

    def peer() -> object:
        return pyastar2d.astar_path(weights, start, goal, allow_diagonal=True)

    navd_ms, peer_ms = paired_ms(ours, peer, repeats)
    return {
        f"astar_uniform_{cells}_navd_ms": round(navd_ms, 2),
        f"astar_uniform_{cells}_pyastar2d_ms": round(peer_ms, 2),
        f"astar_uniform_{cells}_ratio": round(navd_ms / peer_ms, 3),
    }


def _madgwick(repeats: int) -> dict[str, object]:
    messages = drive(FigureEight(), SensorSuite(lidar_hz=0.0), 20.0)
    samples = [m for m in messages if isinstance(m, Imu)]
    settings = NavdConfig().estimation

    def navd_pass() -> None:
        update = MadgwickFilter(settings).update
        for imu in samples:
            update(imu)

    navd_us = 1e3 * min(median_ms(navd_pass, 1) for _ in range(repeats)) / len(samples)
    figures: dict[str, object] = {"madgwick_navd_us_per_sample": round(navd_us, 3)}
    if importlib.util.find_spec("imufusion") is None:
        return figures
    import imufusion  # noqa: PLC0415

    gyro_dps = [np.degrees(np.asarray(s.gyro_radps, dtype=np.float64)) for s in samples]
    accel_g = [np.asarray(s.accel_mps2, dtype=np.float64) / GRAVITY_MPS2 for s in samples]
    period_s = float(np.median(np.diff([s.stamp for s in samples])))
    inputs = list(zip(gyro_dps, accel_g, strict=True))

    def peer_pass() -> None:
        ahrs = imufusion.Ahrs()
        ahrs.set_sample_period(period_s)  # its API takes the period once, not per sample
        update = ahrs.update_no_magnetometer
        for gyro, accel in inputs:
            update(gyro, accel)

    def peer_from_messages() -> None:
        ahrs = imufusion.Ahrs()
        ahrs.set_sample_period(period_s)
        update = ahrs.update_no_magnetometer
        for imu in samples:
            update(np.degrees(np.array(imu.gyro_radps)), np.array(imu.accel_mps2) / GRAVITY_MPS2)

    arrays_us = 1e3 * min(median_ms(peer_pass, 1) for _ in range(repeats)) / len(samples)
    peer_us = 1e3 * min(median_ms(peer_from_messages, 1) for _ in range(repeats)) / len(samples)
    figures["madgwick_imufusion_us_per_sample"] = round(peer_us, 3)
    figures["madgwick_ratio"] = round(navd_us / peer_us, 3)
    figures["madgwick_imufusion_prebuilt_arrays_us_per_sample"] = round(arrays_us, 3)
    figures["madgwick_ratio_to_prebuilt_arrays"] = round(navd_us / arrays_us, 3)
    return figures


def _recorded_ukf_steps() -> tuple[FloatArray, FloatArray, list[tuple[float, Measurement]]]:
    """The lidar pose events of a 60 s drive as the estimator fed them to its UKF: its
    starting state, and (dt, measurement) for each step with the most common rows."""
    from navd.estimation import StateEstimator  # noqa: PLC0415
    from navd.lifecycle.messages import PoseMeasurement, WheelOdometry  # noqa: PLC0415

    estimator = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    ukf = estimator.history.ukf
    recorded: list[tuple[float, Measurement | None]] = []
    first: list[tuple[FloatArray, FloatArray]] = []
    step = ukf.step

    def recording_step(dt_s: float, measurement: Measurement | None, gate: float) -> Any:
        if not first:
            first.append((ukf.x, ukf.p))
        recorded.append((dt_s, measurement))
        return step(dt_s, measurement, gate)

    ukf.step = recording_step  # type: ignore[method-assign, assignment]
    for message in drive(FigureEight(), SensorSuite(), 60.0):
        if isinstance(message, Imu):
            estimator.add_imu(message)
        elif isinstance(message, WheelOdometry):
            estimator.add_wheel_odometry(message, message.received)
        elif isinstance(message, PoseMeasurement):
            estimator.add_pose(message, message.received)
    with_rows = [(dt, m) for dt, m in recorded if m is not None]
    kinds = [m.rows for _, m in with_rows]
    common = max(set(kinds), key=kinds.count)
    x0, p0 = first[0]
    return x0, p0, [(dt, m) for dt, m in with_rows if m.rows == common]


def _ukf() -> dict[str, object]:
    x0, p0, steps = _recorded_ukf_steps()
    estimation = NavdConfig().estimation
    ukf = PoseUkf(UkfSettings.of(estimation))
    ukf.set_state(x0, p0)
    navd_s = []
    for dt, measurement in steps:
        start = time.perf_counter()
        ukf.step(dt, measurement, math.inf)
        navd_s.append(time.perf_counter() - start)
    # In the daemon a step runs every 25-100 ms, between other work: its code and data are
    # out of the caches. The same steps again, each after a pause, time that.
    ukf.set_state(x0, p0)
    spaced_s = []
    for dt, measurement in steps[:SPACED_UKF_STEPS]:
        time.sleep(SPACED_UKF_PAUSE_S)
        start = time.perf_counter()
        ukf.step(dt, measurement, math.inf)
        spaced_s.append(time.perf_counter() - start)
    figures: dict[str, object] = {
        "ukf_step_navd_us_median": round(1e6 * percentile(navd_s, 50), 1),
        "ukf_step_navd_us_median_after_pause": round(1e6 * percentile(spaced_s, 50), 1),
        "ukf_steps": len(steps),
    }
    if importlib.util.find_spec("filterpy") is None:
        return figures
    peer_s = _filterpy_steps(x0, p0, steps, UkfSettings.of(estimation))
    figures["ukf_step_filterpy_us_median"] = round(1e6 * percentile(peer_s, 50), 1)
    figures["ukf_step_ratio"] = round(percentile(navd_s, 50) / percentile(peer_s, 50), 3)
    return figures


def _filterpy_steps(
    x0: FloatArray, p0: FloatArray, steps: list[tuple[float, Measurement]], settings: UkfSettings
) -> list[float]:
    """[s] per step of filterpy's own UKF over ``steps``, with navd's model plugged in."""
    from navd.bench.ukf_reference import stock_filter  # noqa: PLC0415
    from navd.estimation import ProcessNoise  # noqa: PLC0415

    peer = stock_filter(settings, steps[0][1].rows)
    peer.x, peer.P = x0.copy(), p0.copy()
    noise = ProcessNoise(settings.linear_jerk_psd, settings.angular_jerk_psd)
    seconds = []
    for dt, measurement in steps:
        start = time.perf_counter()
        peer.Q = noise(dt)
        peer.predict(dt=dt)
        peer.update(measurement.z, R=measurement.r)
        seconds.append(time.perf_counter() - start)
    return seconds


def run(repeats: int = 9) -> dict[str, object]:
    """Every comparison; ``repeats`` timed runs of each search or pass."""
    figures: dict[str, object] = {
        "peers_missing": [p for p in PEERS if importlib.util.find_spec(p) is None]
    }
    for cells in (400, 2000):
        figures.update(_astar_weighted(cells, repeats))
    for cells in (1000, 2000):
        figures.update(_astar_uniform(cells, repeats))
    figures.update(_madgwick(repeats))
    figures.update(_ukf())
    figures.update(compare_scan.run())
    return figures
