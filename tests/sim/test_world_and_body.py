"""Worlds from shapes and files, moving discs, and the simulated body."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navd.config import NavdConfig
from navd.drivers import WheelCalibration, wheel_command, wheel_speeds
from navd.sim.body import Body, command_velocity, decode_wheels, encode_wheels
from navd.sim.errors import WorldError
from navd.sim.world import Mover, from_shapes, load_world, office

NO_DISCS = np.empty((0, 3))


def test_shapes_are_rasterized_where_they_are() -> None:
    world = from_shapes(
        {
            "resolution_m": 0.02,
            "walls": [[0.0, 0.0, 2.0, 0.0]],
            "boxes": [[1.0, 1.0, 0.5, 0.3]],
            "circles": [[3.0, 1.0, 0.2]],
        }
    )

    def occupied(x: float, y: float) -> bool:
        c = math.floor((x - world.origin_x_m) / world.resolution_m)
        r = math.floor((y - world.origin_y_m) / world.resolution_m)
        return bool(world.grid[r, c])

    assert occupied(1.0, 0.0) and not occupied(1.0, 0.05) and not occupied(2.1, 0.0)
    assert occupied(1.25, 1.15) and not occupied(1.6, 1.15)
    assert occupied(3.0, 1.15) and not occupied(3.0, 1.25)


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ({"walls": [[0, 0, 1, 0]], "doors": []}, "unknown world keys"),
        ({"walls": [[0, 0, 1]]}, r"walls\[0\] must be 4 finite numbers"),
        ({"boxes": [[0, 0, -1, 1]]}, "positive width"),
        ({}, "at least one of walls"),
        ({"walls": [[0, 0, 1, 0]], "resolution_m": 5}, "resolution_m"),
        ({"circles": [[0, 0, 1]], "movers": [{"radius": 0.2}]}, r"movers\[0\]"),
        ({"circles": [[0, 0, 1]], "start": [0, 0]}, r"start\[0\] must be 3"),
        ({"circles": [[0, 0, 1]], "beacons": [{"id": "a", "x": 1}]}, r"beacons\[0\]"),
        ({"circles": [[0, 0, 1]], "beacons": [{"id": "a", "x": 1, "y": "n"}]}, r"beacons\[0\]"),
        (
            {"circles": [[0, 0, 1]], "beacons": [{"id": "a", "x": 1, "y": 0}] * 2},
            "beacon ids must differ",
        ),
    ],
)
def test_bad_worlds_are_refused_by_name(spec, match) -> None:
    with pytest.raises(WorldError, match=match):
        from_shapes(spec)


def test_world_files_load_or_fail_clearly(tmp_path: Path) -> None:
    good = tmp_path / "corridor.toml"
    good.write_text("walls = [[0, 1, 5, 1], [0, -1, 5, -1]]\ngoal = [4, 0, 0]\n")
    world = load_world(good)
    assert world.name == "corridor" and world.goal == (4.0, 0.0, 0.0)
    with pytest.raises(WorldError, match="does not exist"):
        load_world(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("walls = [[0, 1")
    with pytest.raises(WorldError, match=r"bad\.toml"):
        load_world(bad)


def test_office_start_and_goal_are_free() -> None:
    world = office()
    assert world.goal is not None
    for x, y, _ in (world.start, world.goal):
        c = math.floor((x - world.origin_x_m) / world.resolution_m)
        r = math.floor((y - world.origin_y_m) / world.resolution_m)
        assert not world.grid[r - 15 : r + 15, c - 15 : c + 15].any()  # 0.3 m around


def test_movers_go_back_and_forth_along_their_path() -> None:
    mover = Mover(0.2, 1.0, np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]]))
    assert mover.position(0.0) == (0.0, 0.0)
    assert mover.position(2.5) == pytest.approx((2.0, 0.5))
    assert mover.position(3.0) == pytest.approx((2.0, 1.0))
    assert mover.position(4.0) == pytest.approx((2.0, 0.0))  # on the way back
    assert mover.position(6.0) == pytest.approx((0.0, 0.0))


@pytest.mark.parametrize("invert", [(False, False), (True, False), (False, True), (True, True)])
def test_wheel_commands_decode_to_what_the_driver_encoded(invert) -> None:
    cal = WheelCalibration(1000.0, 0, 1000, *invert)
    left, right = wheel_command(*wheel_speeds(0.3, 0.5, 0.3), cal)
    assert decode_wheels(left, right, cal) == pytest.approx((0.225, 0.375), abs=1e-3)
    assert encode_wheels(0.225, 0.375, cal) == (left, right)


def test_the_body_follows_commands_within_its_accelerations() -> None:
    config = NavdConfig()
    world = from_shapes({"walls": [[5.0, -1.0, 5.0, 1.0]]})
    body = Body(0.0, 0.0, 0.0)
    for _ in range(10):
        body.step(0.1, (0.5, 0.0), config, world, NO_DISCS)
    assert body.linear_mps == pytest.approx(0.5)  # reached after 1 s at 0.5 m/s^2
    assert body.x_m == pytest.approx(0.5 * 0.5 * 1.0**2, abs=0.03)
    assert command_velocity(300, 300, config) == pytest.approx((0.3, 0.0))


def test_the_body_stops_at_a_wall_instead_of_passing_through() -> None:
    config = NavdConfig()
    world = from_shapes({"walls": [[1.0, -1.0, 1.0, 1.0]]})
    body = Body(0.0, 0.0, 0.0)
    for _ in range(100):
        body.step(0.05, (0.5, 0.0), config, world, NO_DISCS)
    assert body.collisions > 0
    assert body.x_m < 1.0 - 0.2 and body.min_clearance_m < 0.0


def test_movers_turn_back_rather_than_walk_into_the_robot() -> None:
    from navd.sim.physics import SimRobot

    spec = {
        "walls": [[-1, -2, 5, -2]],
        "movers": [{"radius": 0.2, "speed": 1.0, "path": [[2.0, -1.5], [2.0, 1.5]]}],
    }
    sim = SimRobot(from_shapes(spec), NavdConfig())
    sim.body.x_m, sim.body.y_m = 2.0, 0.0  # standing on the mover's path
    closest = math.inf
    ys = []
    for _ in range(600):
        sim.advance_movers(0.01)
        x, y, radius = sim.discs()[0]
        closest = min(closest, math.hypot(x - 2.0, y) - 0.2 - radius)
        ys.append(y)
    assert 0.0 < closest < 0.06  # it came close, never touched
    assert max(ys) < 0.0 and min(ys[300:]) == pytest.approx(-1.5, abs=0.02)  # and went back


@pytest.mark.parametrize("datum", [False, True])
def test_the_compass_reads_the_true_yaw_back_through_the_daemons_conversion(datum: bool) -> None:
    from navd.estimation import GeoFrame, bearing_to_yaw
    from navd.sim.physics import SimRobot
    from navd.sim.sensors import SensorModels
    from navd.sim.settings import SimSettings

    world_config: dict[str, object] = {"magnetic_declination_deg": 4.5, "map_rotation_rad": 0.3}
    if datum:  # off the zone's central meridian: a grid convergence near a degree
        world_config |= {"datum_latitude_deg": 60.0, "datum_longitude_deg": 14.0}
    config = NavdConfig.model_validate({"world": world_config})
    world = from_shapes({"walls": [[-1, -1, 1, -1]]})
    robot = SimRobot(world, config)
    sensors = SensorModels(robot, config, SimSettings(compass_noise_deg=1e-9))
    convergence = 0.0
    if datum:
        geo = GeoFrame(  # the daemon's frame for that datum
            60.0,
            14.0,
            map_rotation_rad=0.3,
            zone=config.world.utm_zone,
            max_distance_m=config.world.utm_threshold_m,
        )
        convergence = geo.grid_convergence_rad
        assert abs(convergence) > math.radians(0.5)
    for yaw in (-3.0, -1.2, 0.0, 0.7, 2.9):
        robot.body.yaw_rad = yaw
        bearing = sensors.heading(0.0).bearing_deg
        assert 0.0 <= bearing < 360.0
        back = bearing_to_yaw(
            bearing,
            declination_deg=4.5,
            magnetic=True,
            grid_convergence_rad=convergence,
            map_rotation_rad=0.3,
        )
        assert math.remainder(back - yaw, math.tau) == pytest.approx(0.0, abs=1e-6)
