"""The simulator's pure parts: the robot stepped by hand, the sensors read without sockets."""

from __future__ import annotations

import math

import pytest

from navd.config import NavdConfig
from navd.sim.physics import COMMAND_TIMEOUT_S, SimRobot
from navd.sim.sensors import GRAVITY_MPS2, SensorModels
from navd.sim.settings import SimSettings
from navd.sim.world import from_shapes
from navd.wire import ScanFrame, decode_sensor, encode

ROOM = {"walls": [[-2, -2, 2, -2], [2, -2, 2, 2], [2, 2, -2, 2], [-2, 2, -2, -2]]}


def _robot(**config: object) -> SimRobot:
    return SimRobot(from_shapes(ROOM, "room"), NavdConfig.model_validate(config))


def test_wheel_lines_become_commands_and_garbage_is_counted() -> None:
    robot = _robot()
    robot.take_wheel_bytes(b"300 300\n12 x\n", now=1.0)
    robot.take_wheel_bytes(b"-150 ", now=1.1)  # half a line waits for its end
    assert robot.wheels.lines == 1 and robot.wheels.bad_lines == 1
    robot.take_wheel_bytes(b"150\n", now=1.2)
    assert robot.wheels.log == [(1.0, 300, 300), (1.2, -150, 150)]
    assert robot.wheels.command == pytest.approx((0.0, 1.0))  # 0.15 m/s each way, 0.3 m track


def test_the_firmware_watchdog_stops_the_body_when_lines_stop() -> None:
    robot = _robot()
    speeds = {}
    for k in range(1, 301):  # 3 s at 100 Hz; a line every 50 ms for the first second
        t = 0.01 * k
        if k <= 100 and k % 5 == 0:
            robot.take_wheel_bytes(b"300 300\n", now=t)
        robot.step(t, 0.01)
        speeds[k] = robot.body.linear_mps
    assert speeds[100] == pytest.approx(0.3)  # reached after 0.6 s at 0.5 m/s^2
    assert speeds[140] == pytest.approx(0.3)  # the last line still holds 0.4 s later
    assert speeds[100 + round(100 * COMMAND_TIMEOUT_S) + 10] < 0.3  # then the motors stop
    assert speeds[300] == 0.0


def test_encoder_lines_report_the_measured_wheels() -> None:
    robot = _robot(chassis={"invert_left": True})
    robot.body.linear_mps, robot.body.angular_radps = 0.2, 0.0
    assert robot.encoder_line() == b"-200 200\n"


@pytest.mark.parametrize(
    ("mount", "expected"),
    [
        # beams at -pi, -pi/2, 0, pi/2 of the lidar, from 0.5 m ahead of the room's centre
        ({"x_m": 0.5}, [2.5, 2.0, 1.5, 2.0]),
        # the same lidar turned to look backwards: its first beam looks forwards
        ({"x_m": 0.5, "yaw_rad": math.pi}, [1.5, 2.0, 2.5, 2.0]),
    ],
)
def test_a_scan_measures_the_walls_from_the_lidar_mount(
    mount: dict[str, float], expected: list[float]
) -> None:
    config = NavdConfig.model_validate({"lidar": mount})
    robot = SimRobot(from_shapes(ROOM, "room"), config)
    models = SensorModels(robot, config, SimSettings(lidar_noise_m=0.0, lidar_beams=4))
    scan = decode_sensor("lidar", encode(models.scan(3.0)))  # what the daemon reads
    assert isinstance(scan, ScanFrame)
    assert scan.stamp == 3.0 and scan.angle_min == -math.pi
    assert scan.ranges == pytest.approx(expected, abs=0.03)  # the world's 2 cm cells


def test_the_imu_feels_gravity_and_the_turn() -> None:
    robot = _robot()
    robot.body.angular_radps = 0.4
    settings = SimSettings(gyro_noise_radps=0.0, gyro_bias_radps=0.0, accel_noise_mps2=0.0)
    imu = SensorModels(robot, robot.config, settings).imu(1.0)
    assert imu.angular_velocity == pytest.approx((0.0, 0.0, 0.4))
    assert imu.linear_acceleration == pytest.approx((0.0, 0.0, GRAVITY_MPS2))


def test_a_gps_fix_lands_back_on_the_body_through_the_daemons_datum() -> None:
    config = NavdConfig.model_validate(
        {"world": {"datum_latitude_deg": 48.0, "datum_longitude_deg": 11.5}}
    )
    robot = SimRobot(from_shapes(ROOM, "room"), config)
    robot.body.x_m, robot.body.y_m = 1.0, -0.5
    models = SensorModels(robot, config, SimSettings(gps_noise_m=1e-6))
    assert [s.role for s in models.sensors()] == ["lidar", "imu", "gps", "compass"]
    fix = models.fix(2.0)
    assert models.geo is not None
    assert models.geo.to_map(fix.latitude, fix.longitude) == pytest.approx((1.0, -0.5), abs=1e-3)


def test_without_a_datum_there_is_no_gps() -> None:
    robot = _robot()
    roles = [s.role for s in SensorModels(robot, robot.config, SimSettings()).sensors()]
    assert roles == ["lidar", "imu", "compass"]


def test_the_beacon_sensor_ranges_to_each_beacon_in_range_in_turn() -> None:
    spec = {
        **ROOM,
        "beacons": [{"id": "near", "x": 1.0, "y": 1.0}, {"id": "far", "x": 90.0, "y": 0.0}],
    }
    config = NavdConfig()
    robot = SimRobot(from_shapes(spec, "room"), config)
    settings = SimSettings(beacon_range_noise_m=1e-9, beacon_max_range_m=50.0, beacon_mode="both")
    models = SensorModels(robot, config, settings)
    frames = [models.beacon(0.1 * k) for k in range(4)]
    # the far one is out of range: only the near one answers, every time
    assert all(f is not None and f.beacon == "near" for f in frames)
    assert frames[0] is not None and frames[0].range_m == pytest.approx(math.sqrt(2.0))
    assert frames[0].bearing_rad == pytest.approx(math.pi / 4, abs=0.1)  # 0.03 rad noise
    out_of_reach = SensorModels(robot, config, SimSettings(beacon_max_range_m=0.5))
    assert out_of_reach.beacon(0.0) is None
    no_lidar = SensorModels(robot, config, SimSettings(lidar_rate_hz=0.0))
    assert [s.role for s in no_lidar.sensors()] == ["imu", "compass", "beacon"]
