"""Map files: bit-exact reload, map_server conventions read back independently, crash safety."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2, scan_points
from navd.slam import map_io, occupancy
from navd.slam.errors import MapFileError
from navd.slam.map_io import clean_leftovers, load_map, read_map_yaml, save_map
from navd.slam.occupancy import OccupancyGrid


def _grid() -> OccupancyGrid:
    grid = OccupancyGrid(0.05)
    for pose in (Pose2(0, 0, 0), Pose2(2, 1, 1.0)):
        a0, inc, r = cast(pose)
        grid.insert(pose, scan_points(r, a0, inc, range_min=0.1, range_max=30.0))
    return grid


def test_a_saved_map_reloads_bit_exact(tmp_path: Path) -> None:
    grid = _grid()
    path = save_map(grid, tmp_path, "office")
    loaded = load_map(path)
    assert loaded.to_array().dtype == np.float32
    np.testing.assert_array_equal(loaded.to_array(), grid.to_array())
    assert (loaded.origin_x, loaded.origin_y, loaded.resolution) == (
        grid.origin_x,
        grid.origin_y,
        grid.resolution,
    )


def test_a_map_saved_dense_before_the_grid_was_tiled_still_loads(tmp_path: Path) -> None:
    grid = _grid()
    path = save_map(grid, tmp_path, "office", image_stem="map")
    dense = grid.to_array()
    np.savez(  # the state file as navd wrote it with a dense grid
        tmp_path / "map.npz",
        logodds=dense,
        origin=np.array([grid.origin_x, grid.origin_y]),
        resolution=np.array(grid.resolution),
        keyframe_poses=np.zeros((0, 3)),
    )
    loaded = load_map(path)
    np.testing.assert_array_equal(loaded.to_array(), dense)
    assert (loaded.origin_x, loaded.origin_y) == (grid.origin_x, grid.origin_y)


def test_a_state_file_with_malformed_tiles_is_named(tmp_path: Path) -> None:
    grid = _grid()
    path = save_map(grid, tmp_path, "office", image_stem="map")
    state = dict(np.load(tmp_path / "map.npz"))
    state["tile_index"] = state["tile_index"] + 1000  # names tiles the file does not hold
    np.savez(tmp_path / "map.npz", **state)
    with pytest.raises(MapFileError, match=r"map\.npz.*tiles outside"):
        load_map(path)


@pytest.mark.parametrize("band_rows", [None, 7])
def test_yaml_and_pgm_follow_map_server_conventions(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, band_rows: int | None
) -> None:
    if band_rows is not None:  # the image and percentages made in many bands, one partial
        monkeypatch.setattr(map_io, "WRITE_ROWS", band_rows)
        monkeypatch.setattr(occupancy, "PERCENT_ROWS", band_rows - 2)
    grid = _grid()
    assert grid.shape[0] % 7 != 0
    path = save_map(grid, tmp_path, "office")
    meta = yaml.safe_load(path.read_text())
    assert set(meta) == {
        "image",
        "mode",
        "resolution",
        "origin",
        "negate",
        "occupied_thresh",
        "free_thresh",
    }
    assert meta["resolution"] == 0.05 and meta["negate"] == 0
    assert meta["origin"] == [grid.origin_x, grid.origin_y, 0.0]
    image = np.asarray(Image.open(tmp_path / meta["image"]))
    assert image.shape == grid.shape
    # map_server: p = (255 - pixel) / 255; occupied above occupied_thresh, free below free_thresh.
    p = (255.0 - image) / 255.0
    logodds = grid.to_array()[::-1]  # image row 0 is the top (largest y)
    probability = 1.0 - 1.0 / (1.0 + np.exp(logodds.astype(np.float64)))
    occupied = probability > meta["occupied_thresh"]
    free = (probability < meta["free_thresh"]) & (logodds != 0.0)
    assert occupied.any() and free.any()
    assert np.all(p[occupied] > meta["occupied_thresh"])
    assert np.all(p[free] < meta["free_thresh"])
    between = p[~occupied & ~free]  # never seen, or not sure: unknown for map_server
    assert np.all((between >= meta["free_thresh"]) & (between <= meta["occupied_thresh"]))


def test_a_foreign_map_loads_from_its_image(tmp_path: Path) -> None:
    pixels = np.full((4, 6), 205, dtype=np.uint8)
    pixels[0, :] = 0  # the top row is a wall
    pixels[1:, 1:5] = 254
    Image.fromarray(pixels).save(tmp_path / "lab.pgm")
    (tmp_path / "lab.yaml").write_text(
        "image: lab.pgm  # made elsewhere\nresolution: 0.1\norigin: [-1.0, 2.0, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    grid = load_map(tmp_path / "lab.yaml")
    assert (grid.origin_x, grid.origin_y, grid.resolution) == (-1.0, 2.0, 0.1)
    assert np.all(grid.to_array()[3, :] > 0)  # top image row = highest grid row
    assert np.all(grid.to_array()[0:3, 1:5] < 0)
    assert grid.to_array()[0, 0] == 0.0


def test_a_crash_before_the_yaml_is_replaced_leaves_the_old_map(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    first = _grid()
    save_map(first, tmp_path, "office")
    second = _grid()
    a0, inc, r = cast(Pose2(-3, -1, 2.0))
    second.insert(Pose2(-3, -1, 2.0), scan_points(r, a0, inc, range_min=0.1, range_max=30.0))
    real_replace = os.replace

    def crash_on_yaml(src: str, dst: str) -> None:
        if str(dst).endswith(".yaml"):
            raise OSError("power lost")
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", crash_on_yaml)
    with pytest.raises(OSError, match="power lost"):
        save_map(second, tmp_path, "office")
    monkeypatch.undo()
    np.testing.assert_array_equal(load_map(tmp_path / "office.yaml").to_array(), first.to_array())
    assert not list(tmp_path.glob(".*.tmp"))  # no temporary file left behind
    save_map(second, tmp_path, "office")  # the next save succeeds and tidies up
    np.testing.assert_array_equal(load_map(tmp_path / "office.yaml").to_array(), second.to_array())
    assert sorted(p.suffix for p in tmp_path.iterdir()) == [".npz", ".pgm", ".yaml"]


def test_a_state_file_that_fails_half_written_leaves_the_old_map(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    first = _grid()
    save_map(first, tmp_path, "office", image_stem="map")
    second = _grid()
    second = OccupancyGrid.from_array(np.ones(second.shape), second.origin_x, second.origin_y, 0.05)

    def disk_full(file: object, **arrays: object) -> None:
        file.write(b"PK\x03\x04 half a zip")  # type: ignore[attr-defined]
        raise OSError("no space left on device")

    monkeypatch.setattr(np, "savez", disk_full)
    with pytest.raises(OSError, match="no space"):
        save_map(second, tmp_path, "office", image_stem="map")
    monkeypatch.undo()
    np.testing.assert_array_equal(load_map(tmp_path / "office.yaml").to_array(), first.to_array())
    assert not list(tmp_path.glob(".*.tmp"))  # the half-written file is gone


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("image: a.pgm\norigin: [0, 0, 0]\n", "missing key 'resolution'"),
        ("image: a.pgm\nresolution: -1\norigin: [0, 0, 0]\n", "resolution must be > 0"),
        ("image: a.pgm\nresolution: 0.05\norigin: [0, 0]\n", "origin must have 3 numbers"),
        ("image a.pgm\n", "expected 'key: value'"),
    ],
)
def test_malformed_yaml_is_named(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "m.yaml").write_text(text)
    with pytest.raises(MapFileError, match=message):
        read_map_yaml(tmp_path / "m.yaml")


def test_a_missing_or_truncated_image_is_named(tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(MapFileError, match=r"m\.pgm: cannot read the image"):
        load_map(tmp_path / "m.yaml")
    (tmp_path / "m.pgm").write_bytes(b"P5\n4 4\n255\n" + b"\x00" * 5)
    with pytest.raises(MapFileError, match="truncated: 5 of 16"):
        load_map(tmp_path / "m.yaml")


def test_what_cut_saves_left_behind_is_cleaned_and_nothing_else(tmp_path: Path) -> None:
    save_map(_grid(), tmp_path, "office")
    save_map(_grid(), tmp_path, "office")  # revision 2 is the one office.yaml names
    # a crash between the images and the YAML, and one in the middle of a write
    (tmp_path / "office.3.pgm").write_bytes(b"P5\n")
    (tmp_path / "office.3.npz").write_bytes(b"PK")
    (tmp_path / ".office.4.pgm.k2j3h4_x.tmp").write_bytes(b"half")
    (tmp_path / ".office.yaml.abcdefgh.tmp").write_bytes(b"half")
    # what is not a save's: a user's files, a map with no YAML of navd's
    for name in ("notes.txt", ".editor.tmp", "plan.1.pgm", "office.pgm"):
        (tmp_path / name).write_bytes(b"mine")
    removed = clean_leftovers(tmp_path)
    assert sorted(p.name for p in removed) == [
        ".office.4.pgm.k2j3h4_x.tmp",
        ".office.yaml.abcdefgh.tmp",
        "office.3.npz",
        "office.3.pgm",
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        ".editor.tmp",
        "notes.txt",
        "office.2.npz",
        "office.2.pgm",
        "office.pgm",
        "office.yaml",
        "plan.1.pgm",
    ]
    np.testing.assert_array_equal(load_map(tmp_path / "office.yaml").to_array(), _grid().to_array())
    assert clean_leftovers(tmp_path / "absent") == []


def test_a_file_another_map_points_to_is_never_cleaned(tmp_path: Path) -> None:
    # ROS-style names: floor.yaml -> floor.pgm, and a second map floor.2.yaml -> floor.2.pgm
    for name in ("floor", "floor.2"):
        (tmp_path / f"{name}.pgm").write_bytes(b"P5\n1 1\n255\n\x00")
        (tmp_path / f"{name}.yaml").write_text(
            f"image: {name}.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
        )
    assert clean_leftovers(tmp_path) == []
    assert (tmp_path / "floor.2.pgm").exists()
