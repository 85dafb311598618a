"""InvenSense MPU-6050 and MPU-9250 IMUs on I2C (with the MPU-9250's AK8963 magnetometer).

Written from InvenSense's register maps (RM-MPU-6000A, RM-MPU-9250A) and the AK8963
datasheet. Set-up: reset (PWR_MGMT_1 0x6B = 0x80), wake on the gyro's PLL (0x01), the
digital low-pass filter at 44 Hz (CONFIG 0x1A = 3, so the gyro samples at 1 kHz; on the
MPU-9250 it filters the gyro only, and the accelerometer's own filter is set to 44.8 Hz too,
ACCEL_CONFIG2 0x1D = 3), the sample rate divider SMPLRT_DIV 0x19 = 1000 / rate - 1, the gyro
at ±500 °/s (GYRO_CONFIG 0x1B = 0x08: 65.5 LSB per °/s) and the accelerometer at ±4 g
(ACCEL_CONFIG 0x1C = 0x08: 8192 LSB per g). Each poll reads the 14 bytes from ACCEL_XOUT_H
0x3B: accelerations, temperature, angular rates, big-endian. WHO_AM_I 0x75 says 0x68
(MPU-6050) or 0x71/0x73 (MPU-9250/9255).

A chip that lost power for a moment (a brown-out) answers but sleeps, in its reset state,
and reads all zeros: a block of 14 zero bytes is never a measurement (gravity and the
temperature are never both nil), so it is no sample, and the chip is set up again at once.

On the MPU-9250 the magnetometer is reached through the bypass (INT_PIN_CFG 0x37 = 0x02)
at 0x0C: WIA 0x00 says 0x48; its sensitivity adjustments ASA 0x10-0x12 are read in fuse
ROM mode (CNTL1 0x0A = 0x0F), then it runs continuously at 100 Hz with 16-bit output
(CNTL1 = 0x16, 0.15 µT per LSB). A reading (HXL 0x03 to ST2 0x09, little-endian) is new
when ST1 0x02 says so and valid unless ST2 flags an overflow. Its axes are the IMU's with x
and y swapped and z reversed; they are turned into the IMU's here.
"""

from __future__ import annotations

import math
import time

from navd.sensors.errors import ChipError
from navd.sensors.i2c import I2cBus, int16_be, int16_le
from navd.wire import ImuFrame, SensorFrame

__all__ = ["MPU_ADDRESS", "Mpu"]

MPU_ADDRESS = 0x68
AK8963_ADDRESS = 0x0C
GRAVITY_MPS2 = 9.80665
WHO_AM_I = 0x75
PWR_MGMT_1 = 0x6B
SMPLRT_DIV = 0x19
CONFIG = 0x1A
GYRO_CONFIG = 0x1B
ACCEL_CONFIG = 0x1C
ACCEL_CONFIG2 = 0x1D  # MPU-9250 only
INT_PIN_CFG = 0x37
ACCEL_XOUT_H = 0x3B
GYRO_LSB_PER_DPS = 65.5
ACCEL_LSB_PER_G = 8192.0
AK_WIA, AK_ST1, AK_HXL, AK_CNTL1, AK_ASAX = 0x00, 0x02, 0x03, 0x0A, 0x10
AK_UT_PER_LSB = 0.15
IDENTITIES = {"mpu6050": (0x68,), "mpu9250": (0x71, 0x73)}


class Mpu:
    """An MPU-6050 (``kind`` "mpu6050") or MPU-9250 ("mpu9250") on ``bus`` at ``address``.

    Args:
        rate_hz: [Hz] samples per second (4-1000).
    """

    def __init__(
        self, bus: I2cBus, kind: str, address: int = MPU_ADDRESS, rate_hz: float = 200.0
    ) -> None:
        self.bus, self.kind, self.address = bus, kind, address
        self.rate_hz = min(max(rate_hz, 4.0), 1000.0)
        self._mag_adjust: tuple[float, float, float] | None = None
        self._mag_ut: tuple[float, float, float] | None = None
        self.mag_overflows = 0
        self._polls = 0

    def setup(self) -> None:
        bus, address = self.bus, self.address
        who = bus.read_byte_data(address, WHO_AM_I)
        if who not in IDENTITIES[self.kind]:
            raise ChipError(
                f"WHO_AM_I at 0x{address:02X} says 0x{who:02X}, not an {self.kind.upper()} "
                f"(0x{IDENTITIES[self.kind][0]:02X}); check --kind and --address"
            )
        bus.write_byte_data(address, PWR_MGMT_1, 0x80)
        time.sleep(0.1)  # the reset takes up to 100 ms
        bus.write_byte_data(address, PWR_MGMT_1, 0x01)
        bus.write_byte_data(address, CONFIG, 0x03)
        bus.write_byte_data(address, SMPLRT_DIV, round(1000.0 / self.rate_hz) - 1)
        bus.write_byte_data(address, GYRO_CONFIG, 0x08)
        bus.write_byte_data(address, ACCEL_CONFIG, 0x08)
        if self.kind == "mpu9250":
            bus.write_byte_data(address, ACCEL_CONFIG2, 0x03)  # the accelerometer at 44.8 Hz
            self._setup_magnetometer()

    def _setup_magnetometer(self) -> None:
        bus = self.bus
        bus.write_byte_data(self.address, INT_PIN_CFG, 0x02)  # bypass: the AK8963 on the bus
        wia = bus.read_byte_data(AK8963_ADDRESS, AK_WIA)
        if wia != 0x48:
            raise ChipError(f"the MPU-9250's magnetometer (0x0C) says 0x{wia:02X}, not 0x48")
        bus.write_byte_data(AK8963_ADDRESS, AK_CNTL1, 0x00)
        bus.write_byte_data(AK8963_ADDRESS, AK_CNTL1, 0x0F)  # fuse ROM access
        asa = bus.read_i2c_block_data(AK8963_ADDRESS, AK_ASAX, 3)
        self._mag_adjust = tuple((a - 128) / 256.0 + 1.0 for a in asa)  # type: ignore[assignment]
        bus.write_byte_data(AK8963_ADDRESS, AK_CNTL1, 0x00)
        bus.write_byte_data(AK8963_ADDRESS, AK_CNTL1, 0x16)  # 16 bit, continuous 100 Hz

    def poll(self, stamp: float) -> list[SensorFrame]:
        self._polls += 1
        if self._polls % max(round(self.rate_hz), 1) == 0:
            self._check_awake()
        raw = self.bus.read_i2c_block_data(self.address, ACCEL_XOUT_H, 14)
        if not any(raw):
            raise OSError("the chip reads all zeros (it lost power and reset): setting it up again")
        values = [int16_be(raw[i], raw[i + 1]) for i in range(0, 14, 2)]
        ax, ay, az, _temperature, gx, gy, gz = values
        accel = tuple(v / ACCEL_LSB_PER_G * GRAVITY_MPS2 for v in (ax, ay, az))
        gyro = tuple(math.radians(v / GYRO_LSB_PER_DPS) for v in (gx, gy, gz))
        if self._mag_adjust is not None:
            self._read_magnetometer()
        mag = None if self._mag_ut is None else tuple(v * 1e-6 for v in self._mag_ut)
        return [
            ImuFrame(
                stamp=stamp,
                angular_velocity=gyro,  # type: ignore[arg-type]
                linear_acceleration=accel,  # type: ignore[arg-type]
                magnetic_field=mag,  # type: ignore[arg-type]
            )
        ]

    def _check_awake(self) -> None:
        """Once a second: a chip that lost power for a moment answers but sleeps (its reset
        state), reading zeros; that is a lost device, to be set up again.

        Raises:
            OSError: the chip is asleep.
        """
        if self.bus.read_byte_data(self.address, PWR_MGMT_1) & 0x40:
            raise OSError("the chip is asleep (it lost power and reset): setting it up again")

    def _read_magnetometer(self) -> None:
        if not self.bus.read_byte_data(AK8963_ADDRESS, AK_ST1) & 0x01:
            return  # no new reading since the last: the last one stands
        raw = self.bus.read_i2c_block_data(AK8963_ADDRESS, AK_HXL, 7)  # to ST2: ends the read
        if raw[6] & 0x08:
            self.mag_overflows += 1
            return
        assert self._mag_adjust is not None
        hx, hy, hz = (
            int16_le(raw[i], raw[i + 1]) * AK_UT_PER_LSB * self._mag_adjust[i // 2]
            for i in (0, 2, 4)
        )
        self._mag_ut = (hy, hx, -hz)  # into the accelerometer's and gyro's axes

    def counts(self) -> dict[str, int]:
        return {"mag_overflows": self.mag_overflows}
