"""Numba kernels over a grid packed 64 cells to a word, for scanning long runs of cells at once.

``pack_free_cells`` packs which cells of a rows x cols grid are free, for every row and (in a
transposed copy) every column. Lines and cells are padded by one on each side with zeros, so
the map's edge reads as blocked and every scan stops by itself: cell (r, c) is bit
(c + 1) % 64 of word (c + 1) // 64 of row line r + 1, and bit (r + 1) % 64 of word
(r + 1) // 64 of column line c + 1.

``scan_forward`` and ``scan_backward`` find the first cell along a line where a straight jump
of jump point search must stop: a blocked cell, or a cell with a forced neighbour on one of
the two lines beside it (a free side cell whose cell behind it is blocked). That is 64 cells
per step instead of one.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = [
    "bit_of",
    "pack_free_cells",
    "scan_backward",
    "scan_forward",
    "transpose_bits",
]

WordArray = npt.NDArray[np.uint64]

_ONE = np.uint64(1)
_ALL = np.uint64(0xFFFFFFFFFFFFFFFF)
_U63 = np.uint64(63)
# (x & -x) * _DEBRUIJN >> 58 is distinct for each of the 64 single-bit words x.
_DEBRUIJN = np.uint64(0x03F79D71B4CB0A89)
_DEBRUIJN_INDEX = np.zeros(64, dtype=np.int64)
for _bit in range(64):
    _DEBRUIJN_INDEX[(((1 << _bit) * 0x03F79D71B4CB0A89) & (2**64 - 1)) >> 58] = _bit


@njit(cache=True, nogil=True, inline="always")
def _lowest_bit(word: np.uint64) -> int:
    """Index of the lowest set bit of a non-zero word."""
    isolated = word & (~word + _ONE)
    return int(_DEBRUIJN_INDEX[(isolated * _DEBRUIJN) >> np.uint64(58)])


@njit(cache=True, nogil=True, inline="always")
def _highest_bit(word: np.uint64) -> int:
    """Index of the highest set bit of a non-zero word."""
    for shift in (1, 2, 4, 8, 16, 32):
        word |= word >> np.uint64(shift)
    return _lowest_bit(word ^ (word >> _ONE))


@njit(cache=True, nogil=True, inline="always")
def bit_of(line: WordArray, position: int) -> bool:
    """Whether bit ``position`` (padded) of a line is set."""
    return bool((line[position >> 6] >> np.uint64(position & 63)) & _ONE)


@njit(cache=True, nogil=True)
def transpose_bits(bits: WordArray, out: WordArray) -> None:
    """``out`` = the bit matrix ``bits`` transposed, block by block of 64 x 64 bits.

    ``bits`` is (64 * a) x b words (lines of 64 * b bits); ``out`` must be (64 * b) x a.
    """
    block = np.empty(64, dtype=np.uint64)
    for bi in range(bits.shape[0] // 64):
        for bj in range(bits.shape[1]):
            for i in range(64):
                block[i] = bits[bi * 64 + i, bj]
            # Swap ever smaller off-diagonal sub-blocks: 32 x 32, then 16 x 16, ... 1 x 1.
            width = 32
            mask = np.uint64(0x00000000FFFFFFFF)
            while width > 0:
                w = np.uint64(width)
                k = 0
                while k < 64:
                    for i in range(k, k + width):
                        t = ((block[i] >> w) ^ block[i + width]) & mask
                        block[i] ^= t << w
                        block[i + width] ^= t
                    k += 2 * width
                width //= 2
                mask ^= mask << np.uint64(width)
            for i in range(64):
                out[bj * 64 + i, bi] = block[i]


@njit(cache=True, nogil=True)
def _pack_free_rows(blocked: npt.NDArray[np.uint8], out: WordArray) -> None:
    """Line r + 1 of ``out`` (zeroed, padded as the module says) = which cells of row r are
    free (not ``blocked``, read as bytes: a quarter of the memory of the float32 costs).
    Away from the grid's edge a word's 64 cells are read unchecked, in a loop the compiler
    turns into vector compares."""
    rows, cols = blocked.shape
    for r in range(rows):
        row = blocked[r]
        for w in range(out.shape[1]):
            first = 64 * w - 1  # the column of the word's bit 0 (-1: the padding)
            word = np.uint64(0)
            if first >= 0 and first + 64 <= cols:
                cells = row[first : first + 64]
                for j in range(64):
                    word |= np.uint64(cells[j] == 0) << np.uint64(j)
            else:
                for j in range(64):
                    c = first + j
                    if 0 <= c < cols:
                        word |= np.uint64(row[c] == 0) << np.uint64(j)
            out[r + 1, w] = word


def pack_free_cells(blocked: npt.NDArray[np.bool_]) -> tuple[WordArray, WordArray]:
    """Free-cell bit sets of every row and every column of a grid whose ``blocked`` cells
    cannot be entered.

    Returns:
        (rows_free, cols_free): (rows + 2 padded to a multiple of 64) x words, and the same for
        the columns.
    """
    rows, cols = blocked.shape
    row_words = (cols + 2 + 63) // 64
    col_words = (rows + 2 + 63) // 64
    rows_free = np.zeros((64 * col_words, row_words), dtype=np.uint64)
    _pack_free_rows(np.ascontiguousarray(blocked, dtype=np.bool_).view(np.uint8), rows_free)
    cols_free = np.empty((64 * row_words, col_words), dtype=np.uint64)
    transpose_bits(rows_free, cols_free)
    return rows_free, cols_free


@njit(cache=True, nogil=True, inline="always")
def _forced_forward(side: WordArray, w: int) -> np.uint64:
    """Bits x of word w where the side line is free at x and blocked at x - 1."""
    behind = side[w] << _ONE
    if w > 0:
        behind |= side[w - 1] >> _U63
    forced: np.uint64 = side[w] & ~behind
    return forced


@njit(cache=True, nogil=True, inline="always")
def _forced_backward(side: WordArray, w: int) -> np.uint64:
    """Bits x of word w where the side line is free at x and blocked at x + 1."""
    behind = side[w] >> _ONE
    if w + 1 < side.shape[0]:
        behind |= side[w + 1] << _U63
    forced: np.uint64 = side[w] & ~behind
    return forced


@njit(cache=True, nogil=True, inline="always")
def scan_forward(free: WordArray, side_a: WordArray, side_b: WordArray, start: int) -> int:
    """The first padded position >= ``start`` on a line that is blocked or has a forced
    neighbour on ``side_a`` or ``side_b`` (moving towards higher positions)."""
    w = start >> 6
    stop = (~free[w] | _forced_forward(side_a, w) | _forced_forward(side_b, w)) & (
        _ALL << np.uint64(start & 63)
    )
    while stop == 0:
        w += 1
        stop = ~free[w] | _forced_forward(side_a, w) | _forced_forward(side_b, w)
    return 64 * w + _lowest_bit(stop)


@njit(cache=True, nogil=True, inline="always")
def scan_backward(free: WordArray, side_a: WordArray, side_b: WordArray, start: int) -> int:
    """The last padded position <= ``start`` on a line that is blocked or has a forced
    neighbour on ``side_a`` or ``side_b`` (moving towards lower positions)."""
    w = start >> 6
    stop = (~free[w] | _forced_backward(side_a, w) | _forced_backward(side_b, w)) & (
        _ALL >> np.uint64(63 - (start & 63))
    )
    while stop == 0:
        w -= 1
        stop = ~free[w] | _forced_backward(side_a, w) | _forced_backward(side_b, w)
    return 64 * w + _highest_bit(stop)
