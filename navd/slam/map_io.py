"""Map files: the ROS map_server format (.pgm + .yaml) and navd's lossless state beside it.

A save writes ``<name>.<revision>.pgm`` (trinary: occupied 0, free 254, unknown 205, top row
first) and ``<name>.<revision>.npz`` (the float32 log-odds grid, origin, resolution, the
keyframe poses and, when given, the whole pose graph the map was built from: see
``graph_file``), then replaces ``<name>.yaml`` atomically: the YAML is the commit point.
A crash before it leaves the old YAML pointing at the old, complete files; a crash after it
leaves the new ones. Files of older revisions are removed once the YAML points elsewhere.
Every file is written to a temporary name, flushed to disk, then renamed.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import tempfile
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
import numpy.typing as npt

from navd.geometry import FREE_THRESH, OCCUPIED_THRESH, MapYaml, RasterFileError, read_image
from navd.geometry import read_map_yaml as read_raster_yaml
from navd.slam.errors import MapFileError
from navd.slam.graph_file import MapGraph, graph_arrays, graph_from_arrays
from navd.slam.occupancy import OccupancyGrid

__all__ = [
    "MapYaml",
    "SavedMap",
    "clean_leftovers",
    "load_map",
    "load_map_state",
    "read_map_yaml",
    "read_pgm",
    "save_map",
    "saved_files",
]

PIXEL_OCCUPIED, PIXEL_FREE, PIXEL_UNKNOWN = 0, 254, 205
WRITE_ROWS = 512  # image rows written at a time


def _write_atomic(path: Path, data: bytes | Callable[[BinaryIO], None]) -> None:
    """Write ``data`` (bytes, or a function writing them to the open file: a large map is
    streamed, not built in memory first) to ``path`` so that readers see the old file or
    the new, never part."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        # mkstemp makes the file private; a map is for everyone who may read the folder.
        os.fchmod(fd, 0o644)
        with os.fdopen(fd, "wb") as f:
            if isinstance(data, bytes):
                f.write(data)
            else:
                data(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def _pixels(grid: OccupancyGrid, rows: slice) -> npt.NDArray[np.uint8]:
    """The trinary image of the grid's ``rows`` (row 0 = the map's bottom)."""
    occupancy = grid.occupancy_percent(rows)
    pixels = np.full(occupancy.shape, PIXEL_UNKNOWN, dtype=np.uint8)
    pixels[(occupancy >= 0) & (occupancy < FREE_THRESH * 100)] = PIXEL_FREE
    pixels[occupancy > OCCUPIED_THRESH * 100] = PIXEL_OCCUPIED
    return pixels


def _pgm_writer(grid: OccupancyGrid) -> Callable[[BinaryIO], None]:
    """Writes the grid's image as a binary PGM, top row first, made and written a band of
    rows at a time (a large map's image is never held whole)."""

    def write(f: BinaryIO) -> None:
        rows, cols = grid.shape
        f.write(f"P5\n{cols} {rows}\n255\n".encode("ascii"))
        for top in range(rows, 0, -WRITE_ROWS):
            f.write(_pixels(grid, slice(max(top - WRITE_ROWS, 0), top))[::-1].tobytes())

    return write


def read_pgm(path: Path) -> npt.NDArray[np.uint8]:
    """A map image (PGM, or PNG), top row first.

    Raises:
        MapFileError: unreadable or malformed.
    """
    try:
        return read_image(path)
    except RasterFileError as err:
        raise MapFileError(str(err)) from err


def _yaml_text(meta: MapYaml) -> str:
    x, y, yaw = meta.origin
    return (
        f"image: {meta.image}\n"
        f"mode: {meta.mode}\n"
        f"resolution: {meta.resolution!r}\n"
        f"origin: [{x!r}, {y!r}, {yaw!r}]\n"
        f"negate: {meta.negate}\n"
        f"occupied_thresh: {meta.occupied_thresh!r}\n"
        f"free_thresh: {meta.free_thresh!r}\n"
    )


def read_map_yaml(path: Path) -> MapYaml:
    """The flat ``key: value`` YAML of map_server (comments and quotes allowed).

    Raises:
        MapFileError: a missing file, a missing or malformed key (named).
    """
    try:
        return read_raster_yaml(path)
    except RasterFileError as err:
        raise MapFileError(str(err)) from err


def save_map(
    grid: OccupancyGrid,
    directory: Path,
    name: str,
    *,
    keyframe_poses: npt.NDArray[np.float64] | None = None,
    image_stem: str | None = None,
    graph: MapGraph | None = None,
) -> Path:
    """Save ``grid`` as ``directory/name.yaml`` with its image and lossless state.

    Args:
        keyframe_poses: N x 3 (x [m], y [m], yaw [rad]) of the keyframes, for viewers.
        graph: the pose graph the map was built from, so a later run can go on mapping
            with loop closure onto it.
        image_stem: fixed file stem for the image and state ("map" gives map.pgm and
            map.npz) for one-off outputs; None (the default for live saves) numbers them by
            revision so that the set stays consistent through a crash.

    Returns:
        The YAML's path.
    """
    directory.mkdir(parents=True, exist_ok=True)
    yaml_path = directory / f"{name}.yaml"
    stem = image_stem or f"{name}.{_next_revision(directory, name)}"
    _write_atomic(directory / f"{stem}.pgm", _pgm_writer(grid))
    _write_atomic(directory / f"{stem}.npz", _npz_writer(grid, keyframe_poses, graph))
    meta = MapYaml(f"{stem}.pgm", grid.resolution, (grid.origin_x, grid.origin_y, 0.0))
    _write_atomic(yaml_path, _yaml_text(meta).encode("utf-8"))
    _remove_old(directory, name, keep=stem)
    return yaml_path


def saved_files(yaml_path: Path) -> tuple[Path, ...]:
    """The files a save wrote: the YAML, the image it names, and the state beside it."""
    for line in yaml_path.read_text(encoding="utf-8").splitlines():
        if line.startswith("image:"):
            image = yaml_path.parent / line.split(":", 1)[1].strip()
            return (yaml_path, image, image.with_suffix(".npz"))
    return (yaml_path,)


def _npz_writer(
    grid: OccupancyGrid,
    keyframe_poses: npt.NDArray[np.float64] | None,
    graph: MapGraph | None,
) -> Callable[[BinaryIO], None]:
    """Writes the lossless state (log-odds, frame, keyframes, graph) as an .npz."""
    arrays: dict[str, Any] = {
        **grid.state(),
        "keyframe_poses": np.zeros((0, 3)) if keyframe_poses is None else keyframe_poses,
        **({} if graph is None else graph_arrays(graph)),
    }
    return lambda f: np.savez(f, **arrays)


def _next_revision(directory: Path, name: str) -> int:
    pattern = re.compile(rf"^{re.escape(name)}\.(\d+)\.(?:pgm|npz)$")
    found = [int(m.group(1)) for p in directory.iterdir() if (m := pattern.match(p.name))]
    return max(found, default=0) + 1


def _remove_old(directory: Path, name: str, keep: str) -> None:
    pattern = re.compile(rf"^{re.escape(name)}\.(\d+)\.(?:pgm|npz)$")
    for p in directory.iterdir():
        if pattern.match(p.name) and not p.name.startswith(f"{keep}."):
            with contextlib.suppress(FileNotFoundError):
                p.unlink()


def clean_leftovers(directory: Path) -> list[Path]:
    """Remove what saves cut short left in ``directory``: temporary files of unfinished
    writes, and revision images and states no map's YAML points to (written before a crash
    stopped the save from committing them). A file any YAML here points to always stays.
    Returns what was removed; a folder that does not exist, or a file that cannot be read or
    removed, is left as it is.
    """
    try:
        entries = list(directory.iterdir())
    except OSError:
        return []
    removed: list[Path] = []
    kept: dict[str, str] = {}  # map name: the stem its YAML points to
    used: set[str] = set()  # every file a YAML here points to, and its state beside it
    for p in entries:
        if p.suffix == ".yaml":
            with contextlib.suppress(MapFileError, OSError):
                image = Path(read_map_yaml(p).image)
                kept[p.stem] = image.stem
                used.update((image.name, image.with_suffix(".npz").name))
    for p in entries:
        leftover = re.match(r"^\..+\.(?:pgm|npz|yaml)\.[A-Za-z0-9_]+\.tmp$", p.name) is not None
        revision = re.match(r"^(.+)\.\d+\.(?:pgm|npz)$", p.name)
        if revision is not None and revision.group(1) in kept:
            leftover = p.stem != kept[revision.group(1)]
        if leftover and p.name not in used:
            try:
                p.unlink()
            except OSError:
                continue
            removed.append(p)
    return removed


@dataclass(frozen=True, slots=True)
class SavedMap:
    """A map as loaded: its grid, and the pose graph it was built from if it was saved with
    one (None for a map from another tool, or saved without it)."""

    grid: OccupancyGrid
    graph: MapGraph | None = None


def load_map(yaml_path: Path) -> OccupancyGrid:
    """A map saved by navd (exact, from its state file) or by any map_server tool (from the image).

    Raises:
        MapFileError: missing or malformed files, named.
    """
    return load_map_state(yaml_path, with_graph=False).grid


def load_map_state(yaml_path: Path, *, with_graph: bool = True) -> SavedMap:
    """A map with the pose graph it was saved with (navd's state file), or its grid alone.

    Raises:
        MapFileError: missing or malformed files, named.
    """
    meta = read_map_yaml(yaml_path)
    image = yaml_path.parent / meta.image
    state = image.with_suffix(".npz")
    if state.exists():
        try:
            with np.load(state) as data:
                grid = OccupancyGrid.from_state(data)
                graph = graph_from_arrays(data) if with_graph else None
        except (OSError, EOFError, KeyError, ValueError, zipfile.BadZipFile) as err:
            raise MapFileError(f"{state}: unreadable navd map state: {err}") from err
        except (TypeError, IndexError) as err:  # arrays of shapes no save writes
            raise MapFileError(f"{state}: malformed navd map state: {err}") from err
        except MapFileError as err:
            raise MapFileError(f"{state}: {err}") from err
        return SavedMap(grid, graph)
    if not math.isclose(meta.origin[2], 0.0, abs_tol=1e-9):
        raise MapFileError(f"{yaml_path}: rotated map origins (yaw != 0) are not supported")
    pixels = read_pgm(image)[::-1].astype(np.float64)
    occ = pixels / 255.0 if meta.negate else (255.0 - pixels) / 255.0
    logodds = np.zeros(occ.shape, dtype=np.float32)
    logodds[occ > meta.occupied_thresh] = 2.0
    logodds[occ < meta.free_thresh] = -2.0
    return SavedMap(
        OccupancyGrid.from_array(logodds, meta.origin[0], meta.origin[1], meta.resolution)
    )
