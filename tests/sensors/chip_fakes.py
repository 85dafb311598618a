"""Register-level fakes of the I2C chips, written from their datasheets and register maps
(not from navd's drivers): each holds the physical quantities it "measures" and encodes
them the way the chip would under the configuration its registers hold now."""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field

GRAVITY = 9.80665


class FakeBus:
    """An I2C bus with fake chips at their addresses; a missing chip (or ``broken``) raises
    OSError as a real bus does (EREMOTEIO)."""

    def __init__(self, *chips: FakeChip) -> None:
        self.chips: dict[int, FakeChip] = {}
        for chip in chips:
            for address in chip.addresses():
                self.chips[address] = chip
        self.broken = False

    def _chip(self, address: int) -> FakeChip:
        chip = self.chips.get(address)
        if self.broken or chip is None or not chip.answers(address):
            raise OSError(121, "Remote I/O error")
        return chip

    def read_byte_data(self, i2c_addr: int, register: int) -> int:
        return self._chip(i2c_addr).read(i2c_addr, register, 1)[0]

    def write_byte_data(self, i2c_addr: int, register: int, value: int) -> None:
        self._chip(i2c_addr).write(i2c_addr, register, value)

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int) -> list[int]:
        return list(self._chip(i2c_addr).read(i2c_addr, register, length))

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: list[int]) -> None:
        self._chip(i2c_addr).write_block(i2c_addr, register, bytes(data))


class FakeChip:
    """A chip: registers by address, read and written."""

    def write_block(self, address: int, register: int, data: bytes) -> None:
        for i, value in enumerate(data):
            self.write(address, register + i, value)

    def addresses(self) -> tuple[int, ...]:
        raise NotImplementedError

    def answers(self, address: int) -> bool:
        return True

    def read(self, address: int, register: int, length: int) -> bytes:
        raise NotImplementedError

    def write(self, address: int, register: int, value: int) -> None:
        raise NotImplementedError


def _be(value: float) -> bytes:
    return struct.pack(">h", max(-32768, min(32767, round(value))))


def _le(value: float) -> bytes:
    return struct.pack("<h", max(-32768, min(32767, round(value))))


@dataclass
class FakeMpu(FakeChip):
    """An MPU-6050 (who 0x68) or MPU-9250 (who 0x71, with an AK8963 behind the bypass)."""

    who: int = 0x68
    gyro_dps: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel_g: tuple[float, float, float] = (0.0, 0.0, 1.0)
    mag_ut: tuple[float, float, float] = (20.0, -5.0, 40.0)  # in the AK8963's own axes
    asa: tuple[int, int, int] = (176, 176, 165)
    mag_overflow: bool = False
    regs: dict[int, int] = field(default_factory=dict)
    ak: dict[int, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._reset()

    def _reset(self) -> None:
        self.regs = {0x6B: 0x40, 0x1B: 0, 0x1C: 0, 0x37: 0, 0x19: 0, 0x1A: 0}  # asleep
        self.ak = {0x0A: 0x00}

    def addresses(self) -> tuple[int, ...]:
        return (0x68, 0x0C) if self.who != 0x68 else (0x68,)

    def answers(self, address: int) -> bool:
        return address == 0x68 or bool(self.regs[0x37] & 0x02)  # the AK8963 via the bypass

    def write(self, address: int, register: int, value: int) -> None:
        if address == 0x0C:
            self.ak[register] = value
        elif register == 0x6B and value & 0x80:
            self._reset()
        else:
            self.regs[register] = value

    def read(self, address: int, register: int, length: int) -> bytes:
        if address == 0x0C:
            return self._read_ak(register, length)
        if register == 0x75:
            return bytes([self.who])
        if register == 0x3B:
            if self.regs[0x6B] & 0x40:
                return bytes(14)  # asleep: nothing measured
            gyro_lsb = 131.0 / (1 << ((self.regs[0x1B] >> 3) & 3))
            accel_lsb = 16384.0 / (1 << ((self.regs[0x1C] >> 3) & 3))
            data = b"".join(_be(a * accel_lsb) for a in self.accel_g) + _be(0)
            return data + b"".join(_be(g * gyro_lsb) for g in self.gyro_dps)
        return bytes([self.regs.get(register + i, 0) for i in range(length)])

    def _read_ak(self, register: int, length: int) -> bytes:
        mode = self.ak[0x0A]
        if register == 0x00:
            return b"\x48"
        if register == 0x10:
            return bytes(self.asa) if mode == 0x0F else bytes(3)  # fuse ROM mode only
        if register == 0x02:
            return bytes([1 if mode == 0x16 else 0])
        if register == 0x03 and length == 7:
            # raw = field / (0.15 µT x the sensitivity adjustment)
            raw = b"".join(
                _le(m / (0.15 * ((a - 128) / 256 + 1)))
                for m, a in zip(self.mag_ut, self.asa, strict=True)
            )
            return raw + bytes([0x18 if self.mag_overflow else 0x10])  # ST2: BITM, HOFL
        return bytes(length)


@dataclass
class FakeBno055(FakeChip):
    """A BNO055 at 0x28."""

    gyro_rps: tuple[float, float, float] = (0.0, 0.0, 0.5)
    accel_mps2: tuple[float, float, float] = (0.0, 0.0, GRAVITY)
    mag_ut: tuple[float, float, float] = (20.0, 0.0, -40.0)
    heading_deg: float = 123.5
    mag_calibration: int = 3
    regs: dict[int, int] = field(default_factory=lambda: {0x3D: 0x00, 0x3B: 0x80, 0x07: 0})

    def addresses(self) -> tuple[int, ...]:
        return (0x28,)

    def write(self, address: int, register: int, value: int) -> None:
        self.regs[register] = value

    def read(self, address: int, register: int, length: int) -> bytes:
        if register == 0x00:
            return b"\xa0"
        if register == 0x35:
            return bytes([0xC0 | 0x30 | 0x0C | self.mag_calibration])
        if register == 0x08:
            fusing = self.regs[0x3D] in (0x08, 0x09, 0x0A, 0x0B, 0x0C)
            units = self.regs[0x3B]
            accel_lsb = 1000.0 / GRAVITY if units & 0x01 else 100.0  # mg or m/s²
            gyro_lsb = 900.0 if units & 0x02 else 16.0 * 180.0 / math.pi  # rps or dps
            data = b"".join(_le(a * accel_lsb) for a in self.accel_mps2)
            data += b"".join(_le(m * 16.0) for m in self.mag_ut)
            data += b"".join(_le(g * gyro_lsb) for g in self.gyro_rps)
            euler = (
                math.radians(self.heading_deg) * 900.0 if units & 0x04 else self.heading_deg * 16
            )
            data += _le(euler if fusing else 0)  # Euler angles only from a fusion mode
            return (data + bytes(24))[:length]
        return bytes([self.regs.get(register, 0)])


@dataclass
class FakeQmc5883l(FakeChip):
    """A QMC5883L at 0x0D: field in µT (x, y, z)."""

    field_ut: tuple[float, float, float] = (20.0, 0.0, -40.0)
    overflow: bool = False
    regs: dict[int, int] = field(default_factory=lambda: {0x09: 0x00})

    def addresses(self) -> tuple[int, ...]:
        return (0x0D,)

    def write(self, address: int, register: int, value: int) -> None:
        if register == 0x0A and value & 0x80:
            self.regs = {0x09: 0x00}
        else:
            self.regs[register] = value

    def read(self, address: int, register: int, length: int) -> bytes:
        if register == 0x0D:
            return b"\xff"
        if register == 0x00:
            control = self.regs[0x09]
            continuous = control & 0x03 == 0x01
            lsb_per_gauss = 12000.0 if (control >> 4) & 0x03 == 0 else 3000.0
            data = b"".join(_le(f / 100.0 * lsb_per_gauss) for f in self.field_ut)
            status = (0x01 if continuous else 0) | (0x02 if self.overflow else 0)
            return (data + bytes([status]))[:length]
        return bytes([self.regs.get(register, 0)])


@dataclass
class FakeHmc5883l(FakeChip):
    """An HMC5883L at 0x1E: field in µT (x, y, z)."""

    field_ut: tuple[float, float, float] = (20.0, 0.0, -40.0)
    overflow: bool = False
    regs: dict[int, int] = field(default_factory=lambda: {0x00: 0x10, 0x01: 0x20, 0x02: 0x01})

    def addresses(self) -> tuple[int, ...]:
        return (0x1E,)

    def write(self, address: int, register: int, value: int) -> None:
        self.regs[register] = value

    def read(self, address: int, register: int, length: int) -> bytes:
        if register == 0x0A:
            return b"H43"[:length]
        if register == 0x03:
            gains = [1370, 1090, 820, 660, 440, 390, 330, 230]
            lsb = gains[self.regs[0x01] >> 5] / 100.0  # per µT
            x, y, z = (
                (-4096.0, -4096.0, -4096.0)
                if self.overflow
                else tuple(f * lsb for f in self.field_ut)
            )
            if self.regs[0x02] & 0x03 != 0:
                return bytes(6)  # idle or single-shot done: no continuous data
            return _be(x) + _be(z) + _be(y)
        return bytes([self.regs.get(register, 0)])


@dataclass
class FakeIna219(FakeChip):
    """An INA219 at 0x40 between a battery and its load: its 16-bit registers are written
    and read big-endian, two bytes at once (TI SBOS448)."""

    battery_v: float = 12.0
    current_a: float = 1.5  # through the shunt from IN+ to IN- (the load drawing)
    shunt_ohms: float = 0.1
    config: int = 0x399F

    def addresses(self) -> tuple[int, ...]:
        return (0x40,)

    def write_block(self, address: int, register: int, data: bytes) -> None:
        if register == 0x00:
            value = (data[0] << 8) | data[1]
            self.config = 0x399F if value & 0x8000 else value  # a reset: the power-on default

    def read(self, address: int, register: int, length: int) -> bytes:
        shunt_v = self.current_a * self.shunt_ohms
        if register == 0x00:
            value = self.config
        elif register == 0x01:
            value = round(shunt_v / 10e-6) & 0xFFFF
        elif register == 0x02:
            value = round((self.battery_v - shunt_v) / 4e-3) << 3 | 0x02  # CNVR set
        else:
            value = 0
        return struct.pack(">H", value)[:length]
