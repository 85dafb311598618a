"""The packed bit grid and its line scans against plain NumPy references."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navd.planning._bitgrid_kernels import (
    pack_free_cells,
    scan_backward,
    scan_forward,
    transpose_bits,
)


def unpack(words: np.ndarray, length: int) -> np.ndarray:
    """Lines of packed words back to booleans (bit i of word j is position 64 j + i)."""
    as_bytes = words.astype("<u8").view(np.uint8).reshape(words.shape[0], -1)
    return np.unpackbits(as_bytes, axis=1, bitorder="little")[:, :length].astype(bool)


@pytest.mark.parametrize(
    "shape", [(1, 1), (5, 70), (63, 62), (64, 130), (130, 64), (3, 300), (2, 191)]
)
def test_packed_free_cells_match_numpy_rows_columns_and_padding(shape) -> None:
    rng = np.random.default_rng(sum(shape))
    blocked = rng.random(shape) < 0.3
    rows, cols = shape
    rows_free, cols_free = pack_free_cells(blocked)
    free = np.pad(~blocked, 1)  # the padding reads as blocked
    np.testing.assert_array_equal(unpack(rows_free, cols + 2)[: rows + 2], free)
    np.testing.assert_array_equal(unpack(cols_free, rows + 2)[: cols + 2], free.T)
    assert not unpack(rows_free, 64 * rows_free.shape[1])[rows + 2 :].any()
    assert not unpack(rows_free, 64 * rows_free.shape[1])[:, cols + 2 :].any()


@settings(max_examples=50, deadline=None)
@given(st.integers(1, 3), st.integers(1, 3), st.integers(0, 2**31 - 1))
def test_transpose_matches_numpy(blocks_down: int, words_across: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    bits = rng.integers(0, 2**63, size=(64 * blocks_down, words_across), dtype=np.uint64)
    bits ^= rng.integers(0, 2, size=bits.shape, dtype=np.uint64) << np.uint64(63)
    out = np.empty((64 * words_across, blocks_down), dtype=np.uint64)
    transpose_bits(bits, out)
    dense = unpack(bits, 64 * words_across)
    np.testing.assert_array_equal(unpack(out, 64 * blocks_down), dense.T)


def scan_reference(free: np.ndarray, a: np.ndarray, b: np.ndarray, start: int, step: int) -> int:
    """The first position from ``start`` on, moving by ``step``, that is blocked or has a side
    cell free whose cell behind (against ``step``) is blocked."""
    x = start
    while True:
        forced = (a[x] and not a[x - step]) or (b[x] and not b[x - step])
        if not free[x] or forced:
            return x
        x += step


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 200), st.integers(0, 2**31 - 1), st.floats(0.0, 0.4))
def test_scans_find_the_same_stop_as_a_cell_by_cell_walk(length: int, seed: int, p: float) -> None:
    rng = np.random.default_rng(seed)
    lines = np.pad(rng.random((3, length)) >= p, ((0, 0), (1, 1)))  # padded ends are blocked
    words = (length + 2 + 63) // 64
    packed = np.zeros((3, words), dtype=np.uint64)
    for i in range(3):
        for x in np.flatnonzero(lines[i]):
            packed[i, x // 64] |= np.uint64(1) << np.uint64(x % 64)
    start = int(rng.integers(1, length + 1))
    free, a, b = lines
    assert scan_forward(packed[0], packed[1], packed[2], start) == scan_reference(
        free, a, b, start, 1
    )
    assert scan_backward(packed[0], packed[1], packed[2], start) == scan_reference(
        free, a, b, start, -1
    )
