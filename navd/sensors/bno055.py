"""Bosch BNO055 on I2C: its raw IMU data, and its own fused heading as a compass.

Written from Bosch's BNO055 datasheet (BST-BNO055-DS000). Set-up: CHIP_ID 0x00 says 0xA0;
configuration mode (OPR_MODE 0x3D = 0x00), register page 0 (PAGE_ID 0x07), normal power
(PWR_MODE 0x3E = 0x00), units m/s², rad/s, degrees (UNIT_SEL 0x3B = 0x02), then the NDOF
fusion mode (0x0C: accelerometer, gyroscope and magnetometer fused, heading from north).

Each poll reads 24 bytes from ACC_DATA_X_LSB 0x08 (little-endian): acceleration (100 LSB
per m/s²), magnetic field (16 LSB per µT), angular rate (900 LSB per rad/s) and the Euler
heading (16 LSB per degree, clockwise from magnetic north), and CALIB_STAT 0x35. The IMU
sample goes to navd as an IMU; the heading, at most ``heading_rate_hz``, as a compass
reading whose accuracy follows the magnetometer's calibration status (0-3): a heading
from an uncalibrated magnetometer is not sent.

The chip's heading is that of its +y axis (Bosch: 0 when +y points north). navd's compass
readings are the bearing of the device's +x axis, the axis its mount's yaw gives, as for
every other compass: the chip's x axis points 90° clockwise of its y axis (z up), so the
bearing sent is the heading plus 90°. A chip mounted with x forward needs no mount yaw.
"""

from __future__ import annotations

import math
import time

from navd.sensors.errors import ChipError
from navd.sensors.i2c import I2cBus, int16_le
from navd.wire import HeadingFrame, ImuFrame, SensorFrame

__all__ = ["BNO055_ADDRESS", "Bno055"]

BNO055_ADDRESS = 0x28
CHIP_ID, PAGE_ID, ACC_DATA, CALIB_STAT = 0x00, 0x07, 0x08, 0x35
UNIT_SEL, OPR_MODE, PWR_MODE = 0x3B, 0x3D, 0x3E
CONFIG_MODE, NDOF_MODE = 0x00, 0x0C
# [deg] 1-sigma heading accuracy by the magnetometer's calibration status (1, 2, 3)
HEADING_ACCURACY_DEG = {1: 15.0, 2: 6.0, 3: 3.0}
Y_TO_X_DEG = 90.0  # [deg] from the bearing of the chip's +y axis to that of its +x axis


class Bno055:
    """A BNO055 on ``bus`` at ``address`` (0x28, or 0x29 with COM3 high)."""

    def __init__(
        self,
        bus: I2cBus,
        address: int = BNO055_ADDRESS,
        rate_hz: float = 100.0,
        heading_rate_hz: float = 10.0,
    ) -> None:
        self.bus, self.address = bus, address
        self.rate_hz = min(max(rate_hz, 1.0), 100.0)  # its fusion output runs at 100 Hz
        self.heading_period_s = 1.0 / heading_rate_hz
        self._heading_at = -math.inf
        self.uncalibrated = 0
        self._polls = 0

    def setup(self) -> None:
        bus, address = self.bus, self.address
        chip = bus.read_byte_data(address, CHIP_ID)
        if chip != 0xA0:
            raise ChipError(
                f"CHIP_ID at 0x{address:02X} says 0x{chip:02X}, not a BNO055 (0xA0); "
                "check --address (0x28 or 0x29)"
            )
        bus.write_byte_data(address, OPR_MODE, CONFIG_MODE)
        time.sleep(0.025)  # the datasheet's 19 ms from any mode to config mode
        bus.write_byte_data(address, PAGE_ID, 0x00)
        bus.write_byte_data(address, PWR_MODE, 0x00)
        bus.write_byte_data(address, UNIT_SEL, 0x02)  # m/s², rad/s, degrees
        bus.write_byte_data(address, OPR_MODE, NDOF_MODE)
        time.sleep(0.01)  # 7 ms from config mode to a fusion mode

    def poll(self, stamp: float) -> list[SensorFrame]:
        self._polls += 1
        if self._polls % max(round(self.rate_hz), 1) == 0:
            mode = self.bus.read_byte_data(self.address, OPR_MODE) & 0x0F
            if mode != NDOF_MODE:  # a reset chip wakes in config mode, measuring nothing
                raise OSError(f"the chip left its fusion mode (0x{mode:02X}): setting it up again")
        raw = self.bus.read_i2c_block_data(self.address, ACC_DATA, 24)
        v = [int16_le(raw[i], raw[i + 1]) for i in range(0, 24, 2)]
        accel = (v[0] / 100.0, v[1] / 100.0, v[2] / 100.0)
        mag = (v[3] / 16.0 * 1e-6, v[4] / 16.0 * 1e-6, v[5] / 16.0 * 1e-6)
        gyro = (v[6] / 900.0, v[7] / 900.0, v[8] / 900.0)
        frames: list[SensorFrame] = [
            ImuFrame(
                stamp=stamp, angular_velocity=gyro, linear_acceleration=accel, magnetic_field=mag
            )
        ]
        if stamp - self._heading_at >= self.heading_period_s:
            self._heading_at = stamp
            mag_status = self.bus.read_byte_data(self.address, CALIB_STAT) & 0x03
            if mag_status == 0:
                self.uncalibrated += 1  # its heading is not to be trusted yet
            else:
                heading = (v[9] / 16.0 + Y_TO_X_DEG) % 360.0
                frames.append(
                    HeadingFrame(
                        stamp=stamp,
                        bearing_deg=heading,
                        accuracy_deg=HEADING_ACCURACY_DEG[mag_status],
                    )
                )
        return frames

    def counts(self) -> dict[str, int]:
        return {"headings_uncalibrated": self.uncalibrated}
