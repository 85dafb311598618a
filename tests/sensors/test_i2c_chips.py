"""The I2C drivers against register-level fakes: identity checks, the configuration they
write, values in SI units, headings, overflows, and the compass calibration fit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.sensors.bno055 import Bno055
from navd.sensors.errors import CalibrationError, ChipError
from navd.sensors.magnetometer import (
    CompassCalibration,
    Hmc5883l,
    Qmc5883l,
    fit_calibration,
)
from navd.sensors.mpu import Mpu
from navd.wire import HeadingFrame, ImuFrame
from tests.sensors.chip_fakes import (
    GRAVITY,
    FakeBno055,
    FakeBus,
    FakeHmc5883l,
    FakeMpu,
    FakeQmc5883l,
)


def test_an_mpu6050_reads_rates_and_accelerations_in_si_units() -> None:
    chip = FakeMpu(who=0x68, gyro_dps=(10.0, -20.0, 90.0), accel_g=(0.5, -0.25, 1.0))
    mpu = Mpu(FakeBus(chip), "mpu6050", rate_hz=200.0)
    mpu.setup()
    assert chip.regs[0x19] == 4  # 1 kHz / (1 + 4) = 200 Hz
    (frame,) = mpu.poll(5.0)
    assert isinstance(frame, ImuFrame) and frame.stamp == 5.0
    np.testing.assert_allclose(
        frame.angular_velocity, np.radians([10.0, -20.0, 90.0]), atol=np.radians(0.02)
    )
    np.testing.assert_allclose(
        frame.linear_acceleration, [0.5 * GRAVITY, -0.25 * GRAVITY, GRAVITY], atol=0.002
    )
    assert frame.magnetic_field is None


def test_an_mpu9250_adds_its_magnetometer_in_the_imus_axes() -> None:
    chip = FakeMpu(who=0x71, mag_ut=(20.0, -5.0, 40.0))
    mpu = Mpu(FakeBus(chip), "mpu9250")
    mpu.setup()
    assert chip.regs[0x37] & 0x02  # the bypass that puts the AK8963 on the bus
    (frame,) = mpu.poll(1.0)
    assert isinstance(frame, ImuFrame) and frame.magnetic_field is not None
    # x and y swapped, z reversed; tesla; within one LSB (0.15 µT)
    np.testing.assert_allclose(frame.magnetic_field, [-5e-6, 20e-6, -40e-6], atol=0.2e-6)
    chip.mag_overflow = True
    mpu.poll(1.1)
    assert mpu.counts()["mag_overflows"] == 1


def test_an_mpu9250s_accelerometer_is_filtered_like_its_gyro() -> None:
    chip = FakeMpu(who=0x71)
    Mpu(FakeBus(chip), "mpu9250").setup()
    assert chip.regs[0x1A] == 0x03 and chip.regs[0x1D] == 0x03  # 44 Hz and 44.8 Hz
    six = FakeMpu(who=0x68)
    Mpu(FakeBus(six), "mpu6050").setup()
    assert 0x1D not in six.regs  # the MPU-6050's CONFIG filters both; 0x1D is not its


def test_a_chip_that_browned_out_gives_no_zero_sample_and_is_set_up_again() -> None:
    chip = FakeMpu(who=0x68, accel_g=(0.0, 0.0, 1.0))
    mpu = Mpu(FakeBus(chip), "mpu6050", rate_hz=200.0)
    mpu.setup()
    assert len(mpu.poll(1.0)) == 1
    chip.write(0x68, 0x6B, 0x80)  # a brown-out: the chip is in its reset state, asleep
    with pytest.raises(OSError, match="all zeros"):
        mpu.poll(1.005)  # the very next poll, not a second of zeros later
    mpu.setup()
    (frame,) = mpu.poll(1.2)
    assert isinstance(frame, ImuFrame) and frame.linear_acceleration[2] > 9.0


def test_the_wrong_chip_is_refused_by_what_it_says() -> None:
    with pytest.raises(ChipError, match="says 0x68, not an MPU9250"):
        Mpu(FakeBus(FakeMpu(who=0x68)), "mpu9250").setup()
    with pytest.raises(OSError):  # nothing at the address
        Bno055(FakeBus(FakeQmc5883l())).setup()
    with pytest.raises(ChipError, match="not an HMC5883L"):
        bus = FakeBus(FakeHmc5883l())
        bus.chips[0x1E].read = lambda a, r, n: b"ABC"  # type: ignore[method-assign]
        Hmc5883l(bus).setup()


def test_a_bno055_gives_its_imu_data_and_its_heading_as_a_compass() -> None:
    chip = FakeBno055(gyro_rps=(0.0, 0.1, 0.5), heading_deg=123.5)
    bno = Bno055(FakeBus(chip), heading_rate_hz=10.0)
    bno.setup()
    assert chip.regs[0x3D] == 0x0C and chip.regs[0x3B] & 0x02  # NDOF, rad/s
    imu, heading = bno.poll(2.0)
    assert isinstance(imu, ImuFrame) and isinstance(heading, HeadingFrame)
    np.testing.assert_allclose(imu.angular_velocity, [0.0, 0.1, 0.5], atol=0.002)
    np.testing.assert_allclose(imu.linear_acceleration, [0.0, 0.0, GRAVITY], atol=0.01)
    # the chip's heading is its +y axis's; navd's compass bearing is its +x axis's
    assert heading.bearing_deg == pytest.approx(123.5 + 90.0, abs=0.07)
    assert heading.accuracy_deg == 3.0  # fully calibrated magnetometer
    assert len(bno.poll(2.05)) == 1  # headings at 10 Hz, IMU samples at every poll
    chip.mag_calibration = 0
    assert len(bno.poll(2.2)) == 1  # an uncalibrated heading is not sent
    assert bno.counts()["headings_uncalibrated"] == 1


@pytest.mark.parametrize(("fake", "driver"), [(FakeQmc5883l, Qmc5883l), (FakeHmc5883l, Hmc5883l)])
def test_a_magnetometer_gives_the_bearing_of_its_x_axis(fake: type, driver: type) -> None:
    chip = fake()
    compass = driver(FakeBus(chip))
    compass.setup()
    for bearing in (0.0, 45.0, 90.0, 200.0, 315.0):
        # x forward, y left: facing bearing b, north is at b to the left of forward
        b = math.radians(bearing)
        chip.field_ut = (30.0 * math.cos(b), 30.0 * math.sin(b), -40.0)
        (frame,) = compass.poll(1.0)
        assert isinstance(frame, HeadingFrame)
        error = (frame.bearing_deg - bearing + 180.0) % 360.0 - 180.0
        assert abs(error) < 0.5
    chip.overflow = True
    assert compass.poll(2.0) == []
    assert compass.counts()["overflows"] == 1


def _turn(hard: tuple[float, float], soft: np.ndarray, samples: int = 200) -> np.ndarray:
    rng = np.random.default_rng(11)
    angles = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
    true = 30.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    distorted = true @ soft.T + hard
    return distorted + rng.normal(0.0, 0.2, distorted.shape)


def test_the_calibration_fit_undoes_hard_and_soft_iron() -> None:
    soft = np.array([[1.3, 0.2], [0.2, 0.8]])
    raw = _turn((12.0, -7.0), soft)
    fit = fit_calibration(raw)
    assert fit.hard_iron_ut == pytest.approx((12.0, -7.0), abs=0.3)
    fixed = np.array([fit.apply(x, y) for x, y in raw])
    radii = np.hypot(fixed[:, 0], fixed[:, 1])
    assert radii.std() / radii.mean() < 0.02  # a circle again
    # bearings come out right up to one rotation common to all (the mount's yaw)
    angles = np.linspace(0.0, 2.0 * math.pi, 200, endpoint=False)
    got = np.arctan2(fixed[:, 1], fixed[:, 0])
    offset = np.angle(np.mean(np.exp(1j * (got - angles))))
    residual = np.angle(np.exp(1j * (got - angles - offset)))
    assert np.degrees(np.abs(residual)).max() < 3.0
    uncalibrated = np.arctan2(raw[:, 1] + 7.0, raw[:, 0] - 12.0)  # the offset alone removed
    assert np.degrees(np.abs(np.angle(np.exp(1j * (uncalibrated - angles))))).max() > 10.0


def test_a_calibration_without_a_turn_is_refused() -> None:
    raw = _turn((0.0, 0.0), np.eye(2))[:40]  # under a quarter of a turn
    with pytest.raises(CalibrationError, match="turn"):
        fit_calibration(raw)
    with pytest.raises(CalibrationError, match="at least 20"):
        fit_calibration(raw[:5])
    assert CompassCalibration().apply(3.0, 4.0) == (3.0, 4.0)
