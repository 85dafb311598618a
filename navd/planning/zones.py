"""Zones drawn as images: a keep-out mask and a speed-limit mask, aligned with the map.

Each is a map_server raster (YAML + PGM or PNG, see ``geometry.raster_file``), like Nav2's
filter masks. Keep-out: occupied cells (black in a trinary image) are never entered, as if
they were walls. Speed: a cell's value 1..100 is the top speed there in % of
``robot.max_linear_speed_mps`` (give the image in ``raw`` mode, a pixel's value being the
percent, or in ``scale`` mode); 0 and unknown cells set no limit. A mask file is read again
when it changes on disk (looked at once a second), so a person redraws a zone while navd
runs; the config names the files and may change too.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from navd.geometry import RasterFileError, occupancy_of, read_image, read_map_yaml
from navd.planning.costmap import GridFrame
from navd.planning.errors import PlanningError

__all__ = ["RECHECK_S", "ZoneError", "ZoneMask", "ZoneMasks", "load_zone_mask"]

RECHECK_S = 1.0  # [s] how often the files' modification times are looked at
# Readings are numbered across every ZoneMasks of the process: a cache keyed by the number
# never mistakes another file's first reading for the one it holds.
_READINGS = itertools.count(1)
BoolArray = npt.NDArray[np.bool_]


class ZoneError(PlanningError):
    """A zone mask cannot be read; goals are refused until it can (a keep-out zone that
    is not known cannot be kept out of)."""


@dataclass(frozen=True, slots=True)
class ZoneMask:
    """A raster on the map: ``values`` per cell (row = y; -1 unknown, 0..100).

    Attributes:
        frame: where it lies.
        values: the cells.
        path: the YAML it came from; stamp: the YAML's and the image's modification times.
    """

    frame: GridFrame
    values: npt.NDArray[np.int8]
    path: str
    stamp: tuple[int, int]

    def cells_on(self, frame: GridFrame) -> npt.NDArray[np.int8]:
        """The mask's value at each cell centre of ``frame`` (-1 outside the mask)."""
        res = frame.resolution_m
        xs = frame.origin_x_m + (np.arange(frame.cols) + 0.5) * res
        ys = frame.origin_y_m + (np.arange(frame.rows) + 0.5) * res
        mine = self.frame
        cols = np.floor((xs - mine.origin_x_m) / mine.resolution_m).astype(np.int64)
        rows = np.floor((ys - mine.origin_y_m) / mine.resolution_m).astype(np.int64)
        col_ok = (cols >= 0) & (cols < mine.cols)
        row_ok = (rows >= 0) & (rows < mine.rows)
        out = np.full(frame.shape, -1, dtype=np.int8)
        picked = self.values[np.ix_(rows[row_ok], cols[col_ok])]
        out[np.ix_(np.nonzero(row_ok)[0], np.nonzero(col_ok)[0])] = picked
        return out

    def value_at(self, x_m: float, y_m: float) -> int:
        """The value of the cell holding map point (x_m, y_m) (-1 outside)."""
        row, col = self.frame.cell_of(x_m, y_m)
        if 0 <= row < self.frame.rows and 0 <= col < self.frame.cols:
            return int(self.values[row, col])
        return -1


def load_zone_mask(path: Path) -> ZoneMask:
    """The mask described by the YAML at ``path``.

    Raises:
        ZoneError: the YAML or its image is missing or malformed (named), or the origin is
            rotated.
    """
    try:
        stamp = _stamp(path)
        meta = read_map_yaml(path)
        pixels = read_image(path.parent / meta.image)
    except (RasterFileError, OSError) as err:
        raise ZoneError(f"zone mask: {err}") from err  # err names the file
    if not math.isclose(meta.origin[2], 0.0, abs_tol=1e-9):
        raise ZoneError(f"zone mask {path}: a rotated origin (yaw != 0) is not supported")
    values = occupancy_of(meta, pixels)
    rows, cols = values.shape
    frame = GridFrame(meta.resolution, meta.origin[0], meta.origin[1], rows, cols)
    return ZoneMask(frame, values, str(path), stamp)


class ZoneMasks:
    """The keep-out and speed masks the config names, read again when their files change.

    Args:
        keep_out: the keep-out mask's YAML, or None; speed: the speed mask's, or None.
    """

    def __init__(self, keep_out: str | None, speed: str | None) -> None:
        self.paths = (keep_out, speed)
        self.keep_out: ZoneMask | None = None
        self.speed: ZoneMask | None = None
        self.error = ""
        self.revision = 0  # a new number whenever a mask is read anew
        self._checked_s = -math.inf
        self.refresh(0.0, force=True)

    def refresh(self, now: float, *, force: bool = False) -> bool:
        """Read a mask whose file changed (at most every RECHECK_S); True if one did."""
        if not force and now - self._checked_s < RECHECK_S:
            return False
        self._checked_s = now
        changed = False
        errors = []
        for index, path in enumerate(self.paths):
            current = (self.keep_out, self.speed)[index]
            if path is None:
                continue
            try:
                if current is not None and _stamp(Path(path)) == current.stamp:
                    continue
                mask = load_zone_mask(Path(path))
            except (ZoneError, RasterFileError, OSError) as err:
                errors.append(str(err))
                continue
            if index == 0:
                self.keep_out = mask
            else:
                self.speed = mask
            changed = True
        self.error = "; ".join(errors)
        if changed:
            self.revision = next(_READINGS)
        return changed

    def check(self) -> None:
        """Raise if a mask the config names could not be read.

        Raises:
            ZoneError: naming the file and what is wrong with it.
        """
        if self.error:
            raise ZoneError(self.error)

    def keep_out_cells(self, frame: GridFrame) -> BoolArray:
        """The cells of ``frame`` a keep-out mask forbids."""
        if self.keep_out is None:
            return np.zeros(frame.shape, dtype=np.bool_)
        forbidden: BoolArray = self.keep_out.cells_on(frame) >= 100
        return forbidden

    def speed_fraction_at(self, x_m: float, y_m: float) -> float:
        """The top speed at map point (x_m, y_m) as a fraction of the robot's (1: none)."""
        if self.speed is None:
            return 1.0
        value = self.speed.value_at(x_m, y_m)
        return 1.0 if value <= 0 else min(value, 100) / 100.0

    def speed_fraction_on(self, *points_m: tuple[float, float]) -> float:
        """The lowest top speed at any of ``points_m`` (where the robot is, where it heads),
        as a fraction of the robot's (1: no speed zone)."""
        return min((self.speed_fraction_at(x, y) for x, y in points_m), default=1.0)


def _stamp(yaml_path: Path) -> tuple[int, int]:
    """The modification times [ns] of a mask's YAML and of the image it names.

    Raises:
        RasterFileError, OSError: either cannot be read.
    """
    meta = read_map_yaml(yaml_path)
    return yaml_path.stat().st_mtime_ns, (yaml_path.parent / meta.image).stat().st_mtime_ns
