"""Beacons on the real daemon driving the simulated robot (lockstep): four UWB-like range
beacons at known places and no lidar keep the estimate on the truth while a "visit all
beacons" mission drives to each of them; beacons the config does not list are learnt from
bearings, shown in status and visited; a beacon step naming one with no place fails by its
policy."""

from __future__ import annotations

import dataclasses
import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.sim import Session, from_shapes, office, session
from navd.wire import (
    InitialPoseFrame,
    MissionFrame,
    MissionStatusFrame,
    Reply,
    StatusFrame,
    SubscribeFrame,
)
from tests.e2e.missions import follow_mission

pytestmark = pytest.mark.e2e

# A 14 m square yard, a beacon (a UWB anchor) near each corner; the robot starts by one.
BEACONS = {"B1": (1.0, 1.0), "B2": (11.0, 1.5), "B3": (10.5, 11.0), "B4": (1.5, 10.0)}
YARD: dict[str, Any] = {
    "resolution_m": 0.05,
    "walls": [[-1.0, -1.0, 13.0, -1.0], [13.0, -1.0, 13.0, 13.0], [13.0, 13.0, -1.0, 13.0],
              [-1.0, 13.0, -1.0, -1.0]],
    "beacons": [{"id": b, "x": x, "y": y} for b, (x, y) in BEACONS.items()],
    "start": [3.0, 2.5, 0.0],
}  # fmt: skip
NO_LIDAR = {"lidar_rate_hz": 0.0, "beacon_rate_hz": 20.0, "beacon_range_noise_m": 0.1}


def _known(beacons: dict[str, tuple[float, float]]) -> dict[str, Any]:
    return {"beacons": {"known": {b: {"x_m": x, "y_m": y} for b, (x, y) in beacons.items()}}}


async def _run(
    s: Session, mission: MissionFrame, limit_s: float
) -> tuple[list[MissionStatusFrame], list[tuple[float, float, float]]]:
    """Send ``mission``; every mission status up to its end, and the daemon's pose
    (stamp [s], x, y [m]) from each status it sent meanwhile."""
    await s.control.request(SubscribeFrame(rate_hz=10.0))
    poses: list[tuple[float, float, float]] = []

    def pose_of(frame: Reply) -> None:
        if isinstance(frame, StatusFrame) and frame.pose is not None:
            poses.append((frame.stamp, frame.pose.x, frame.pose.y))

    return await follow_mission(s, mission, limit_s, pose_of), poses


def _errors_m(s: Session, poses: list[tuple[float, float, float]]) -> np.ndarray:
    """[m] each status pose's distance from the simulated robot at the status's time."""
    truth = np.array([(t, x, y) for t, x, y, _ in s.sim.truth])
    stamps = np.array([p[0] for p in poses])
    inside = (stamps >= truth[0, 0]) & (stamps <= truth[-1, 0])
    stamps = stamps[inside]
    xy = np.array([p[1:] for p in poses])[inside]
    true_x = np.interp(stamps, truth[:, 0], truth[:, 1])
    true_y = np.interp(stamps, truth[:, 0], truth[:, 2])
    return np.hypot(xy[:, 0] - true_x, xy[:, 1] - true_y)


async def test_range_beacons_without_a_lidar_localize_a_visit_of_every_beacon(
    tmp_path: Path,
) -> None:
    mission = MissionFrame.model_validate(
        {
            "mission_id": "tour",
            "steps": [{"kind": "visit_beacons", "stop_distance": 0.6}],
        }
    )
    world = from_shapes(YARD, "yard")
    async with session(
        world, tmp_path, overrides=_known(BEACONS), sim_settings=NO_LIDAR, lockstep=True,
        hold_clock=True,
    ) as s:  # fmt: skip
        seen, poses = await _run(s, mission, limit_s=300.0)
        truth = [(x, y) for _, x, y, _ in s.sim.truth]
        errors = _errors_m(s, poses)
    assert seen[-1].state == "completed", seen[-1]
    # each beacon was reached: the robot came within the stop distance and a little of it
    for b, (x, y) in BEACONS.items():
        nearest = min(math.hypot(px - x, py - y) for px, py in truth)
        assert nearest < 0.6 + 0.35, f"{b}: nearest {nearest:.2f} m"
    driven = sum(math.dist(a, b) for a, b in itertools.pairwise(truth))
    assert driven > 25.0  # a tour of the yard, not a drive on the spot
    assert len(errors) > 100
    assert float(errors.max()) <= 0.3, f"worst {errors.max():.3f} m, mean {errors.mean():.3f} m"


async def test_a_beacon_step_whose_beacon_has_no_place_follows_its_policy(
    tmp_path: Path,
) -> None:
    mission = MissionFrame.model_validate(
        {
            "mission_id": "lost",
            "steps": [
                {"kind": "beacon", "beacon": "B9", "on_failure": "skip"},
                {"kind": "beacon", "beacon": "B1", "stop_distance": 0.6},
            ],
        }
    )
    world = from_shapes(YARD, "yard")
    async with session(
        world, tmp_path, overrides=_known(BEACONS), sim_settings=NO_LIDAR, lockstep=True,
        hold_clock=True,
    ) as s:  # fmt: skip
        seen, _ = await _run(s, mission, limit_s=120.0)
    failed = [f for f in seen if f.event == "step_skipped"]
    assert failed and failed[0].step == 1
    assert "B9 has no place" in failed[0].reason and "B1" in failed[0].reason
    assert seen[-1].state == "completed" and seen[-1].done == 1 and seen[-1].failed == 1


async def test_beacons_learnt_from_bearings_show_in_status_and_are_visited(
    tmp_path: Path,
) -> None:
    # the office, localized by its lidar (SLAM); two beacons the config does not list, seen
    # by bearing only (a camera reading tags, 0.03 rad noise)
    learnt = {"T1": (2.0, 1.8), "T2": (10.0, 5.0)}
    world = dataclasses.replace(office(), beacons=tuple((b, x, y) for b, (x, y) in learnt.items()))
    bearings = {"beacon_mode": "bearing", "beacon_bearing_noise_rad": 0.03}
    mission = MissionFrame.model_validate(
        {
            "mission_id": "scout",
            "steps": [
                {"kind": "goto", "x": 3.5, "y": 3.2},
                {"kind": "goto", "x": 8.5, "y": 3.2},
                {"kind": "visit_beacons", "stop_distance": 0.6},
            ],
        }
    )
    async with session(world, tmp_path, sim_settings=bearings, lockstep=True, hold_clock=True) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        seen, _ = await _run(s, mission, limit_s=300.0)
        status = await _latest_status(s)
        truth = [(x, y) for _, x, y, _ in s.sim.truth]
    assert seen[-1].state == "completed", seen[-1]
    places = {b.id: b for b in status.beacons}
    assert set(places) == set(learnt)
    for b, (x, y) in learnt.items():
        place = places[b]
        assert place.learnt and math.dist((place.x, place.y), (x, y)) <= 0.2, place
        nearest = min(math.hypot(px - x, py - y) for px, py in truth)
        assert nearest < 0.6 + 0.35, f"{b}: nearest {nearest:.2f} m"


async def _latest_status(s: Session) -> StatusFrame:
    """The next status frame (the session subscribed in ``_run``)."""
    while True:
        frame = await s.control.receive(5.0)
        if isinstance(frame, StatusFrame):
            return frame
