"""Rasters placed on the map as ROS's map_server writes them: a flat YAML (image, resolution,
origin, negate, thresholds, mode) beside a PGM or PNG image, the image's top row the map's
far edge. SLAM's maps and the planner's zone masks are both read through here."""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from navd.geometry.errors import RasterFileError

__all__ = [
    "FREE_THRESH",
    "MAX_IMAGE_PIXELS",
    "OCCUPIED_THRESH",
    "MapYaml",
    "RasterFileError",
    "occupancy_of",
    "read_image",
    "read_map_yaml",
]

OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196
# [pixels] the largest image read: 8000 x 8000 (400 m square at 5 cm; the largest map of the
# public benchmark logs, fr-clinic, is 4680 x 8645). Checked from the header before a pixel
# is decoded: a 439 KB PNG can claim 20000 x 20000 and take gigabytes to decode.
MAX_IMAGE_PIXELS = 64_000_000
MODES = ("trinary", "scale", "raw")


@dataclass(frozen=True, slots=True)
class MapYaml:
    """The keys of a map_server YAML file."""

    image: str
    resolution: float
    origin: tuple[float, float, float]
    negate: int = 0
    occupied_thresh: float = OCCUPIED_THRESH
    free_thresh: float = FREE_THRESH
    mode: str = "trinary"


def read_map_yaml(path: Path) -> MapYaml:
    """The flat ``key: value`` YAML of map_server (comments and quotes allowed).

    Raises:
        RasterFileError: a missing file, a missing or malformed key (named).
    """
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise RasterFileError(f"{path}: cannot read the map YAML: {err}") from err
    values: dict[str, str] = {}
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        key, sep, value = line.partition(":")
        if not sep:
            raise RasterFileError(f"{path}: expected 'key: value', got {line!r}")
        values[key.strip()] = value.strip().strip("'\"")
    try:
        origin = tuple(float(v) for v in values["origin"].strip("[]").split(","))
        if len(origin) != 3:
            raise ValueError("origin must have 3 numbers")
        meta = MapYaml(
            image=values["image"],
            resolution=float(values["resolution"]),
            origin=(origin[0], origin[1], origin[2]),
            negate=int(values.get("negate", "0")),
            occupied_thresh=float(values.get("occupied_thresh", str(OCCUPIED_THRESH))),
            free_thresh=float(values.get("free_thresh", str(FREE_THRESH))),
            mode=values.get("mode", "trinary"),
        )
    except KeyError as err:
        raise RasterFileError(f"{path}: missing key {err.args[0]!r}") from err
    except ValueError as err:
        raise RasterFileError(f"{path}: malformed value: {err}") from err
    if not meta.resolution > 0.0:
        raise RasterFileError(f"{path}: resolution must be > 0, got {meta.resolution}")
    if meta.mode not in MODES:
        raise RasterFileError(f"{path}: mode {meta.mode!r} is not one of {', '.join(MODES)}")
    return meta


def read_image(path: Path) -> npt.NDArray[np.uint8]:
    """An 8-bit grey image, top row first: a binary PGM (P5) read here, a PNG through
    Pillow (colour is turned to grey, as map_server does; an alpha channel is dropped).

    Raises:
        RasterFileError: unreadable, not an image of these kinds, or larger than
            ``MAX_IMAGE_PIXELS``.
    """
    try:
        data = path.read_bytes()
    except OSError as err:
        raise RasterFileError(f"{path}: cannot read the image: {err}") from err
    if data.startswith(b"P5"):
        header = re.match(rb"P5\s+(?:#[^\n]*\s+)*(\d+)\s+(?:#[^\n]*\s+)*(\d+)\s+(\d+)\s", data)
        if header is None or int(header.group(3)) != 255:
            raise RasterFileError(f"{path}: not a binary 8-bit PGM (P5, maxval 255)")
        cols, rows = int(header.group(1)), int(header.group(2))
        _within_cap(path, cols, rows)
        body = data[header.end() :]
        if len(body) < rows * cols:
            raise RasterFileError(f"{path}: truncated: {len(body)} of {rows * cols} pixel bytes")
        return np.frombuffer(body[: rows * cols], dtype=np.uint8).reshape(rows, cols).copy()
    if data.startswith(b"\x89PNG"):
        from io import BytesIO  # noqa: PLC0415

        from PIL import Image, UnidentifiedImageError  # noqa: PLC0415 - only PNG masks

        try:
            with warnings.catch_warnings():  # (Pillow's own bomb warning: the cap is ours)
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                image = Image.open(BytesIO(data))  # (reads the header only)
            with image:
                _within_cap(path, *image.size)
                return np.asarray(image.convert("L"), dtype=np.uint8).copy()
        except Image.DecompressionBombError as err:  # far beyond the cap: said at open
            raise RasterFileError(
                f"{path}: more pixels than the {MAX_IMAGE_PIXELS} navd reads ({err})"
            ) from err
        except (OSError, UnidentifiedImageError) as err:
            raise RasterFileError(f"{path}: a broken PNG: {err}") from err
    raise RasterFileError(f"{path}: not a PGM (P5) or PNG image")


def _within_cap(path: Path, cols: int, rows: int) -> None:
    if cols * rows > MAX_IMAGE_PIXELS:
        raise RasterFileError(
            f"{path}: {cols} x {rows} pixels is more than the {MAX_IMAGE_PIXELS} navd reads; "
            "use a coarser resolution or crop the image"
        )


def occupancy_of(meta: MapYaml, pixels: npt.NDArray[np.uint8]) -> npt.NDArray[np.int8]:
    """map_server's reading of an image, bottom row first (row = y): -1 unknown, 0 free,
    100 occupied; in ``scale`` mode the values between the thresholds as 1..99 %, in ``raw``
    mode each pixel's value itself (0-100; above 100 unknown)."""
    grey = pixels[::-1].astype(np.float64)
    if meta.mode == "raw":
        raw = grey.astype(np.int16)
        return np.where(raw > 100, -1, raw).astype(np.int8)
    p = grey / 255.0 if meta.negate else (255.0 - grey) / 255.0
    out = np.full(p.shape, -1, dtype=np.int8)
    out[p > meta.occupied_thresh] = 100
    out[p < meta.free_thresh] = 0
    if meta.mode == "scale":
        between = (p >= meta.free_thresh) & (p <= meta.occupied_thresh)
        span = max(meta.occupied_thresh - meta.free_thresh, 1e-9)
        scaled = np.clip(np.rint(99.0 * (p - meta.free_thresh) / span), 1, 99)
        out[between] = scaled[between].astype(np.int8)
    return out
