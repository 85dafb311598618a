"""QMC5883L and HMC5883L magnetometers on I2C as compasses, with hard- and soft-iron
calibration.

Written from the QST QMC5883L and Honeywell HMC5883L datasheets.

- QMC5883L (0x0D): chip id 0x0D says 0xFF; soft reset (0x0A = 0x80), SET/RESET period
  (0x0B = 0x01), then continuous at 200 Hz, ±8 G, 512 over-sampling (0x09 = 0x1D: 3000 LSB
  per gauss). Status 0x06: bit 0 data ready, bit 1 overflow. Data 0x00-0x05: x, y, z
  little-endian.
- HMC5883L (0x1E): identification 0x0A-0x0C says "H43"; 8-sample average at 75 Hz
  (CRA 0x00 = 0x78), gain 1.3 G (CRB 0x01 = 0x20: 1090 LSB per gauss), continuous (MODE
  0x02 = 0x00). Data 0x03-0x08: x, z, y big-endian; -4096 is an overflow.

One gauss is 100 µT. The heading is taken with the chip level, its x axis forward, y to the
left and z up (turn it on its mount otherwise): bearing = atan2(y, x) of the calibrated
field, clockwise from magnetic north. Calibration: a robot turning in place sees the
horizontal field trace an ellipse, off-centre by the robot's own magnetism (hard iron) and
squashed by nearby steel (soft iron). ``fit_calibration`` fits the ellipse and gives the
centre and the matrix that turn it back into a circle of the same area.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.sensors.errors import CalibrationError, ChipError
from navd.sensors.i2c import I2cBus, int16_be, int16_le
from navd.wire import HeadingFrame, SensorFrame

__all__ = [
    "HMC5883L_ADDRESS",
    "QMC5883L_ADDRESS",
    "CompassCalibration",
    "Hmc5883l",
    "Magnetometer",
    "Qmc5883l",
    "fit_calibration",
]

QMC5883L_ADDRESS = 0x0D
HMC5883L_ADDRESS = 0x1E
GAUSS_UT = 100.0
HEADING_ACCURACY_DEG = 5.0  # [deg] a calibrated magnetometer on a robot, near motors


@dataclass(frozen=True, slots=True)
class CompassCalibration:
    """Calibrated field = soft_iron (raw - hard_iron), in the horizontal plane.

    Attributes:
        hard_iron_ut: [µT] the centre of the field's ellipse.
        soft_iron: 2 x 2 matrix, row by row.
    """

    hard_iron_ut: tuple[float, float] = (0.0, 0.0)
    soft_iron: tuple[tuple[float, float], tuple[float, float]] = ((1.0, 0.0), (0.0, 1.0))

    def apply(self, x_ut: float, y_ut: float) -> tuple[float, float]:
        """The calibrated horizontal field [µT]."""
        dx, dy = x_ut - self.hard_iron_ut[0], y_ut - self.hard_iron_ut[1]
        (a, b), (c, d) = self.soft_iron
        return a * dx + b * dy, c * dx + d * dy


def fit_calibration(xy_ut: npt.ArrayLike) -> CompassCalibration:
    """The calibration that turns the horizontal field of a turn in place into a circle.

    Args:
        xy_ut: [µT] N x 2 raw horizontal field samples, taken over at least one full turn.

    Raises:
        CalibrationError: too few samples, or they do not trace an ellipse (the robot did not turn).
    """
    points = np.asarray(xy_ut, dtype=np.float64)
    if points.ndim != 2 or points.shape[0] < 20:
        raise CalibrationError(f"{len(points)} samples: need at least 20 over a full turn")
    x, y = points[:, 0], points[:, 1]
    # a x² + b xy + c y² + d x + e y = 1, in least squares
    design = np.column_stack([x * x, x * y, y * y, x, y])
    (a, b, c, d, e), *_ = np.linalg.lstsq(design, np.ones_like(x), rcond=None)
    shape = np.array([[a, b / 2.0], [b / 2.0, c]])
    eigenvalues = np.linalg.eigvalsh(shape)
    if eigenvalues.min() <= 0.0:
        raise CalibrationError("the samples do not trace an ellipse: turn the robot a full circle")
    centre = -0.5 * np.linalg.solve(shape, [d, e])
    level = 1.0 + float(centre @ shape @ centre)
    normal = shape / level  # (p - centre)ᵀ normal (p - centre) = 1
    values, vectors = np.linalg.eigh(normal)
    root = vectors @ np.diag(np.sqrt(values)) @ vectors.T  # maps the ellipse to the unit circle
    radius = float(np.prod(values) ** -0.25)  # the circle of the ellipse's area
    soft = root * radius
    bearings = np.sort(np.arctan2(y - centre[1], x - centre[0]))
    gaps = np.diff(np.concatenate([bearings, [bearings[0] + 2.0 * math.pi]]))
    if 2.0 * math.pi - gaps.max() < 1.5 * math.pi:
        raise CalibrationError(
            "the samples cover under three quarters of a turn: turn a full circle"
        )
    return CompassCalibration(
        (float(centre[0]), float(centre[1])),
        ((float(soft[0, 0]), float(soft[0, 1])), (float(soft[1, 0]), float(soft[1, 1]))),
    )


class Magnetometer:
    """What both chips share: a heading from each new reading, through the calibration.

    Attributes:
        rate_hz: [Hz] how often it is read.
        last_ut: [µT] the latest raw (x, y, z), for calibrating.
    """

    address: int
    rate_hz: float

    def __init__(self, bus: I2cBus, calibration: CompassCalibration | None = None) -> None:
        self.bus = bus
        self.calibration = calibration or CompassCalibration()
        self.last_ut: tuple[float, float, float] | None = None
        self.overflows = 0
        self.not_ready = 0

    def heading(self, stamp: float, field_ut: tuple[float, float, float]) -> HeadingFrame:
        """The compass reading of a raw field [µT]."""
        self.last_ut = field_ut
        x, y = self.calibration.apply(field_ut[0], field_ut[1])
        bearing = math.degrees(math.atan2(y, x)) % 360.0
        return HeadingFrame(
            stamp=stamp,
            bearing_deg=bearing if bearing < 360.0 else 0.0,
            accuracy_deg=HEADING_ACCURACY_DEG,
        )

    def counts(self) -> dict[str, int]:
        return {"overflows": self.overflows, "not_ready": self.not_ready}


class Qmc5883l(Magnetometer):
    """A QMC5883L on ``bus`` (see the module docstring)."""

    def __init__(
        self,
        bus: I2cBus,
        calibration: CompassCalibration | None = None,
        address: int = QMC5883L_ADDRESS,
        rate_hz: float = 50.0,
    ) -> None:
        super().__init__(bus, calibration)
        self.address, self.rate_hz = address, rate_hz

    def setup(self) -> None:
        bus, address = self.bus, self.address
        chip = bus.read_byte_data(address, 0x0D)
        if chip != 0xFF:
            raise ChipError(f"chip id at 0x{address:02X} says 0x{chip:02X}, not a QMC5883L (0xFF)")
        bus.write_byte_data(address, 0x0A, 0x80)
        bus.write_byte_data(address, 0x0B, 0x01)
        bus.write_byte_data(address, 0x09, 0x1D)

    def poll(self, stamp: float) -> list[SensorFrame]:
        raw = self.bus.read_i2c_block_data(self.address, 0x00, 7)
        status = raw[6]
        if status & 0x02:
            self.overflows += 1
            return []
        if not status & 0x01:
            self.not_ready += 1
            return []
        scale = GAUSS_UT / 3000.0
        field = tuple(int16_le(raw[i], raw[i + 1]) * scale for i in (0, 2, 4))
        return [self.heading(stamp, (field[0], field[1], field[2]))]


class Hmc5883l(Magnetometer):
    """An HMC5883L on ``bus`` (see the module docstring)."""

    def __init__(
        self,
        bus: I2cBus,
        calibration: CompassCalibration | None = None,
        address: int = HMC5883L_ADDRESS,
        rate_hz: float = 50.0,
    ) -> None:
        super().__init__(bus, calibration)
        self.address, self.rate_hz = address, min(rate_hz, 75.0)

    def setup(self) -> None:
        bus, address = self.bus, self.address
        ident = bytes(bus.read_i2c_block_data(address, 0x0A, 3))
        if ident != b"H43":
            raise ChipError(
                f"identification at 0x{address:02X} says {ident!r}, not an HMC5883L (b'H43')"
            )
        bus.write_byte_data(address, 0x00, 0x78)
        bus.write_byte_data(address, 0x01, 0x20)
        bus.write_byte_data(address, 0x02, 0x00)

    def poll(self, stamp: float) -> list[SensorFrame]:
        raw = self.bus.read_i2c_block_data(self.address, 0x03, 6)
        x, z, y = (int16_be(raw[i], raw[i + 1]) for i in (0, 2, 4))
        if -4096 in (x, y, z):
            self.overflows += 1
            return []
        scale = GAUSS_UT / 1090.0
        return [self.heading(stamp, (x * scale, y * scale, z * scale))]
