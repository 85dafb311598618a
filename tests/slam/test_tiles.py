"""The tiled array: the same cells as a dense array, stored only where written."""

from __future__ import annotations

import numpy as np
import pytest

from navd.slam import _grid_kernels as k
from navd.slam.tiles import TILE, TiledArray


def _sparse(rows: int, cols: int, seed: int) -> np.ndarray:
    """A float32 array mostly of zeros: a few written blocks scattered over it."""
    rng = np.random.default_rng(seed)
    dense = np.zeros((rows, cols), dtype=np.float32)
    for _ in range(6):
        r, c = int(rng.integers(0, rows - 20)), int(rng.integers(0, cols - 20))
        dense[r : r + 20, c : c + 20] = rng.uniform(-2.0, 3.5, (20, 20))
    return dense


def test_a_dense_array_comes_back_whole_and_in_any_window() -> None:
    dense = _sparse(300, 170, seed=1)
    store = TiledArray.from_dense(dense)
    np.testing.assert_array_equal(store.window(0, 300, 0, 170), dense)
    np.testing.assert_array_equal(store.window(37, 201, 5, 150), dense[37:201, 5:150])
    # a window reaching past the array is clipped to it
    np.testing.assert_array_equal(store.window(-10, 400, 160, 200), dense[:, 160:170])
    # only tiles with something written in them are stored
    blocks = np.pad(dense, ((0, 20), (0, 22))).reshape(5, TILE, 3, TILE).any(axis=(1, 3))
    np.testing.assert_array_equal(store.index >= 0, blocks)
    assert store.allocated_bytes == blocks.sum() * TILE * TILE * 4


def test_growing_at_the_low_edges_moves_the_cells_and_no_tile() -> None:
    dense = _sparse(100, 90, seed=2)
    store = TiledArray.from_dense(dense)
    tiles_before = store.tiles[: int(store.used[0])].copy()
    store.grow(100 + 13 + 70, 90 + 200 + 5, 13, 200)  # 13 rows below, 200 columns left
    grown = np.zeros((183, 295), dtype=np.float32)
    grown[13:113, 200:290] = dense
    np.testing.assert_array_equal(store.window(0, 183, 0, 295), grown)
    np.testing.assert_array_equal(store.tiles[: int(store.used[0])], tiles_before)
    with pytest.raises(ValueError, match="only grows"):
        store.grow(10, 10, 0, 0)


def test_reserve_makes_room_for_every_empty_tile_a_box_touches() -> None:
    # 10 x 10 tiles, one written (room for exactly that one)
    dense = np.zeros((640, 640), dtype=np.float32)
    dense[3, 3] = 1.0
    store = TiledArray.from_dense(dense)
    assert store.tiles.shape[0] == int(store.used[0]) == 1
    store.reserve(10, 200, 0, 639)  # rows in tiles 0..3, all columns: 40, one written
    assert store.tiles.shape[0] >= 40
    store.reserve(-50, 5000, -50, 5000)  # clipped to the array: all 100 tiles
    assert store.tiles.shape[0] >= 100 and int(store.used[0]) == 1
    np.testing.assert_array_equal(store.window(0, 640, 0, 640), dense)  # moved, unchanged


def test_the_state_remakes_the_array_exactly_and_bad_parts_are_named() -> None:
    store = TiledArray.from_dense(_sparse(150, 260, seed=3))
    store.grow(150 + 9, 260 + 11, 9, 11)
    again = TiledArray.from_parts(**_parts(store))
    np.testing.assert_array_equal(again.window(0, 159, 0, 271), store.window(0, 159, 0, 271))
    np.testing.assert_array_equal(again.index, store.index)
    assert (again.off_r, again.off_c) == (store.off_r, store.off_c)
    parts = _parts(store)
    with pytest.raises(ValueError, match="tiles outside"):
        TiledArray.from_parts(parts["index"], parts["tiles"][:1], parts["offset"], parts["shape"])
    with pytest.raises(ValueError, match=r"not the .* tiles it needs"):
        TiledArray.from_parts(parts["index"][:1], parts["tiles"], parts["offset"], parts["shape"])
    with pytest.raises(ValueError, match="float32"):
        TiledArray.from_parts(
            parts["index"], parts["tiles"].astype(np.float64), parts["offset"], parts["shape"]
        )
    twice = parts["index"].copy()
    twice[twice >= 0] = 0
    with pytest.raises(ValueError, match="one tile for two places"):
        TiledArray.from_parts(twice, parts["tiles"], parts["offset"], parts["shape"])
    for offset, match in (([np.inf, 0.0], "not integers"), ([64, 0], "within one tile")):
        with pytest.raises(ValueError, match=match):
            TiledArray.from_parts(parts["index"], parts["tiles"], np.array(offset), parts["shape"])
    with pytest.raises(ValueError, match="tile_index holds float"):
        TiledArray.from_parts(
            parts["index"].astype(float), parts["tiles"], parts["offset"], parts["shape"]
        )


def test_tiles_read_from_a_file_in_fortran_order_are_written_to_as_any() -> None:
    store = TiledArray.from_dense(np.full((100, 100), 0.5))  # every tile written: no room made
    parts = _parts(store)
    again = TiledArray.from_parts(
        parts["index"], np.asfortranarray(parts["tiles"]), parts["offset"], parts["shape"]
    )
    for each in (again, store):
        each.reserve(0, 99, 0, 99)
    cells = np.array([5, 70], dtype=np.int64)
    for each in (again, store):
        hits = np.ones(2, bool)
        k.ray_update(
            *each.parts(), 50, 50, cells, cells[::-1].copy(), hits, -0.4, 0.85, -2.0, 3.5, 0
        )
    np.testing.assert_array_equal(again.window(0, 100, 0, 100), store.window(0, 100, 0, 100))


def _parts(store: TiledArray) -> dict[str, np.ndarray]:
    state = store.state()
    return {
        "index": state["tile_index"],
        "tiles": state["tiles"],
        "offset": state["tile_offset"],
        "shape": state["shape"],
    }
