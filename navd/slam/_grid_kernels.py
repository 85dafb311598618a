"""Numba kernels of the occupancy grid and the correlative scan matcher.

Grids are indexed [row, col] = [y, x] in cells. The occupancy grid is stored in tiles
(navd.slam.tiles); its kernels take the tiled array's parts. Every kernel has a NumPy twin,
on a dense array, in tests/slam/grid_reference.py.

- ``extent``, ``cells_and_box``: a scan's box in the world and its end cells, for
  ``ray_update``.
- ``ray_update``: log-odds update along each ray (Bresenham): every cell the ray crosses
  gets ``l_free``, the end cell of a ray that hit something gets ``l_occ``; values are
  clamped to [l_min, l_max].
- ``smear``: the correlation grid of seed Appendix A: every occupied cell stamps a Gaussian
  kernel, keeping the maximum where stamps overlap.
- ``doubled_max``: the sliding maximum M[v, u] = max of the field over [v, v+2h) x
  [u, u+2h), an upper bound of the field over a block of 2h x 2h translations (the levels of
  branch and bound), made from the one over h x h.
- ``fine_scores``: the summed field under the scan points, rotated and moved, for a block
  of translations.
- ``branch_and_bound``: the best (rotation, translation) over a whole window, less a pull
  toward the prior (stronger along the scan's weak axis), best-first over blocks of
  translations bounded by the summed sliding maximum (the tracking matcher and the global
  search).
- ``best_among``: the best summed field under the scan points, at one rotation, over the
  translations a mask allows (the best rival of a match), best-first like
  ``branch_and_bound``.
- ``count_known``: how many world points lie within one cell of an observed cell
  (log-odds not 0).
"""

from __future__ import annotations

import heapq

import numba as nb
import numpy as np
import numpy.typing as npt

from navd.slam.tiles import TILE, TILE_MASK, TILE_SHIFT

__all__ = [
    "best_among",
    "branch_and_bound",
    "cells_and_box",
    "count_known",
    "doubled_max",
    "extent",
    "fine_scores",
    "ray_update",
    "smear",
    "smear_cells",
]

FloatArray = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
I32Grid = npt.NDArray[np.int32]
Tiles = npt.NDArray[np.float32]  # [n, TILE, TILE]


@nb.njit(cache=True, nogil=True)
def _tile_to_write(index: I32Grid, used: IntArray, gy: int, gx: int) -> int:
    """The tile holding tile-numbered cell (gy, gx), allocated if it was not yet (the
    caller reserved room: see TiledArray.reserve)."""
    t = index[gy >> TILE_SHIFT, gx >> TILE_SHIFT]
    if t < 0:
        t = used[0]
        used[0] = t + 1
        index[gy >> TILE_SHIFT, gx >> TILE_SHIFT] = t
    return int(t)


@nb.njit(cache=True, nogil=True, inline="always")
def _read(index: I32Grid, tiles: Tiles, gy: int, gx: int) -> float:
    """Tile-numbered cell (gy, gx); 0 in a tile never written."""
    t = index[gy >> TILE_SHIFT, gx >> TILE_SHIFT]
    if t < 0:
        return 0.0
    return float(tiles[t, gy & TILE_MASK, gx & TILE_MASK])


@nb.njit(cache=True, nogil=True)
def extent(points: F64, x: float, y: float) -> tuple[float, float, float, float]:
    """(min x, min y, max x, max y) [m] of ``points`` (N x 2) and the point (x, y); all four
    NaN if any of them is not finite (the caller refuses the scan)."""
    lo_x = hi_x = x
    lo_y = hi_y = y
    for i in range(points.shape[0]):
        px, py = points[i, 0], points[i, 1]
        if not (np.isfinite(px) and np.isfinite(py)):
            return np.nan, np.nan, np.nan, np.nan
        lo_x, hi_x = min(lo_x, px), max(hi_x, px)
        lo_y, hi_y = min(lo_y, py), max(hi_y, py)
    if not (np.isfinite(x) and np.isfinite(y)):
        return np.nan, np.nan, np.nan, np.nan
    return lo_x, lo_y, hi_x, hi_y


@nb.njit(cache=True, nogil=True)
def cells_and_box(
    points: F64, origin_x: float, origin_y: float, res: float, col: int, row: int
) -> tuple[IntArray, IntArray, int, int, int, int]:
    """The cells (col, row) = floor((point - origin) / res) of ``points`` (N x 2 [m]), and
    the box of those cells and the cell (col, row): (cols, rows, col min, col max, row min,
    row max)."""
    n = points.shape[0]
    cols = np.empty(n, dtype=np.int64)
    rows = np.empty(n, dtype=np.int64)
    c0 = c1 = col
    r0 = r1 = row
    for i in range(n):
        c = int(np.floor((points[i, 0] - origin_x) / res))
        r = int(np.floor((points[i, 1] - origin_y) / res))
        cols[i], rows[i] = c, r
        c0, c1 = min(c0, c), max(c1, c)
        r0, r1 = min(r0, r), max(r1, r)
    return cols, rows, c0, c1, r0, r1


@nb.njit(cache=True, nogil=True)
def ray_update(
    index: I32Grid,
    tiles: Tiles,
    used: IntArray,
    off_r: int,
    off_c: int,
    rows: int,
    cols: int,
    x0: int,
    y0: int,
    ends_x: IntArray,
    ends_y: IntArray,
    hits: npt.NDArray[np.bool_],
    l_free: float,
    l_occ: float,
    l_min: float,
    l_max: float,
    keep: int,
) -> None:
    """Free the cells from (x0, y0) to each end (exclusive); mark hit ends occupied. The
    grid is the tiled array of the first seven arguments (TiledArray.parts). A hit's ray
    stops freeing ``keep`` cells before its end (Chebyshev): on cells finer than the
    lidar's noise, a ray grazing a wall would otherwise free the wall's cells beside its
    own end."""
    cells = tiles.reshape(-1)  # tile t's cell (a, b) is at t * TILE² + a * TILE + b
    for k in range(ends_x.size):
        x1, y1 = ends_x[k], ends_y[k]
        stop = keep if hits[k] else 0
        dx = abs(x1 - x0)
        dy = -abs(y1 - y0)
        sx = 1 if x0 < x1 else -1
        sy = 1 if y0 < y1 else -1
        err = dx + dy
        # Walked in the tiles' own numbering (the steps do not depend on where it starts).
        gx, gy = x0 + off_c, y0 + off_r
        gx1, gy1 = x1 + off_c, y1 + off_r
        tile_r = tile_c = -1  # the tile the ray is in, and where its cells start
        first = 0
        # A ray between two cells of the grid never leaves it (the grid's cells are a
        # rectangle and a ray's cells lie between its ends): its cells need no check. The
        # same walk with a check follows, for a ray with an end off the grid.
        if 0 <= x0 < cols and 0 <= y0 < rows and 0 <= x1 < cols and 0 <= y1 < rows:
            while max(abs(gx1 - gx), abs(gy1 - gy)) > stop:
                if gy >> TILE_SHIFT != tile_r or gx >> TILE_SHIFT != tile_c:
                    tile_r, tile_c = gy >> TILE_SHIFT, gx >> TILE_SHIFT
                    # _tile_to_write written out: called, even inlined, it made this walk
                    # 1.2-1.7 times slower than on a dense grid; like this it is as fast.
                    t = index[tile_r, tile_c]
                    if t < 0:
                        t = used[0]
                        used[0] = t + 1
                        index[tile_r, tile_c] = t
                    first = t << (2 * TILE_SHIFT)
                i = first + ((gy & TILE_MASK) << TILE_SHIFT) + (gx & TILE_MASK)
                cells[i] = max(cells[i] + l_free, l_min)
                e2 = 2 * err
                if e2 >= dy:
                    err += dy
                    gx += sx
                if e2 <= dx:
                    err += dx
                    gy += sy
        while max(abs(gx1 - gx), abs(gy1 - gy)) > stop:  # (a ray inside the grid ended here)
            if 0 <= gx - off_c < cols and 0 <= gy - off_r < rows:
                if gy >> TILE_SHIFT != tile_r or gx >> TILE_SHIFT != tile_c:
                    tile_r, tile_c = gy >> TILE_SHIFT, gx >> TILE_SHIFT
                    first = _tile_to_write(index, used, gy, gx) << (2 * TILE_SHIFT)
                i = first + ((gy & TILE_MASK) << TILE_SHIFT) + (gx & TILE_MASK)
                cells[i] = max(cells[i] + l_free, l_min)
            e2 = 2 * err
            if e2 >= dy:
                err += dy
                gx += sx
            if e2 <= dx:
                err += dx
                gy += sy
        if hits[k] and 0 <= x1 < cols and 0 <= y1 < rows:
            gy, gx = y1 + off_r, x1 + off_c
            t = _tile_to_write(index, used, gy, gx)
            v = tiles[t, gy & TILE_MASK, gx & TILE_MASK] + l_occ
            tiles[t, gy & TILE_MASK, gx & TILE_MASK] = min(v, l_max)


@nb.njit(cache=True, nogil=True, inline="always")
def _stamp(kernel: FloatArray, field: FloatArray, fy: int, fx: int) -> None:
    """field = max(field, kernel) over the kernel's square centred on field cell (fy, fx),
    the part inside the field."""
    f_rows, f_cols = field.shape
    r = kernel.shape[0] // 2
    for ky in range(-r, r + 1):
        y = fy + ky
        if y < 0 or y >= f_rows:
            continue
        for kx in range(-r, r + 1):
            x = fx + kx
            if 0 <= x < f_cols:
                w = kernel[ky + r, kx + r]
                field[y, x] = max(field[y, x], w)


@nb.njit(cache=True, nogil=True)
def smear(
    index: I32Grid,
    tiles: Tiles,
    used: IntArray,
    off_r: int,
    off_c: int,
    rows: int,
    cols: int,
    threshold: float,
    row0: int,
    col0: int,
    kernel: FloatArray,
    field: FloatArray,
) -> None:
    """Stamp ``kernel`` (odd square) into ``field`` around every cell above ``threshold``.

    The grid is the tiled array of the first seven arguments (TiledArray.parts); ``field``
    covers its window starting at (row0, col0) with its own shape; cells of the grid
    outside the window stamp nothing, and tiles never written are skipped whole. ``field``
    must be zeroed by the caller.
    """
    f_rows, f_cols = field.shape
    g0, g1 = max(row0, 0) + off_r, min(row0 + f_rows, rows) + off_r  # tile numbering
    h0, h1 = max(col0, 0) + off_c, min(col0 + f_cols, cols) + off_c
    if g0 >= g1 or h0 >= h1:
        return
    for tr in range(g0 >> TILE_SHIFT, ((g1 - 1) >> TILE_SHIFT) + 1):
        for tc in range(h0 >> TILE_SHIFT, ((h1 - 1) >> TILE_SHIFT) + 1):
            t = index[tr, tc]
            if t < 0:
                continue
            for gy in range(max(g0, tr * TILE), min(g1, (tr + 1) * TILE)):
                fy = gy - off_r - row0
                for gx in range(max(h0, tc * TILE), min(h1, (tc + 1) * TILE)):
                    if tiles[t, gy & TILE_MASK, gx & TILE_MASK] > threshold:
                        _stamp(kernel, field, fy, gx - off_c - col0)


@nb.njit(cache=True, nogil=True)
def smear_cells(
    index: I32Grid,
    tiles: Tiles,
    used: IntArray,
    off_r: int,
    off_c: int,
    rows: int,
    cols: int,
    threshold: float,
    cells: npt.NDArray[np.int64],
    row0: int,
    col0: int,
    kernel: FloatArray,
    field: FloatArray,
) -> None:
    """``smear`` of the listed grid cells only (N x 2 (col, row)): each one inside the
    field's window and above ``threshold`` stamps ``kernel`` into ``field`` (whose cell
    (0, 0) is the grid's (row0, col0)); the field is not zeroed first."""
    f_rows, f_cols = field.shape
    for i in range(cells.shape[0]):
        col, row = cells[i, 0], cells[i, 1]
        if not (0 <= row < rows and 0 <= col < cols):
            continue
        if not (0 <= row - row0 < f_rows and 0 <= col - col0 < f_cols):
            continue
        gy, gx = row + off_r, col + off_c
        t = index[gy >> TILE_SHIFT, gx >> TILE_SHIFT]
        if t < 0 or tiles[t, gy & TILE_MASK, gx & TILE_MASK] <= threshold:
            continue
        _stamp(kernel, field, row - row0, col - col0)


@nb.njit(cache=True, nogil=True)
def doubled_max(half: FloatArray, h: int) -> FloatArray:
    """The sliding maximum over 2h x 2h cells (clipped at the border) from ``half``, the one
    over h x h (h [cells]; the field itself for h = 1): the maximum over [u, u + 2h) is that
    over [u, u + h) and over [u + h, u + 2h)."""
    rows, cols = half.shape
    out = np.empty_like(half)
    # One pass, row by row: (v, u), (v, u + h), (v + h, u), (v + h, u + h), clipped.
    for v in range(rows):
        below = v + h < rows
        for u in range(cols):
            m = half[v, u]
            right = u + h < cols
            if right and half[v, u + h] > m:
                m = half[v, u + h]
            if below:
                m = max(m, half[v + h, u])
                if right and half[v + h, u + h] > m:
                    m = half[v + h, u + h]
            out[v, u] = m
    return out


@nb.njit(cache=True, nogil=True)
def _project(px: F64, py: F64, c: float, s: float, tx: float, ty: float, k: int) -> tuple[int, int]:
    """Cell of point k rotated by (c, s) and moved by (tx, ty); all in cell units."""
    x = c * px[k] - s * py[k] + tx
    y = s * px[k] + c * py[k] + ty
    return int(np.floor(x + 0.5)), int(np.floor(y + 0.5))


@nb.njit(cache=True, nogil=True)
def _block_bound(
    bound: FloatArray, cols: IntArray, rows: IntArray, dx: int, dy: int, size: int
) -> float:
    """Summed ``bound`` (the sliding maximum over ``size`` cells) under the projected points
    moved by (dx, dy) cells, float32-rounded. A point whose block of cells starts before the
    field's first row or column but reaches into it takes the bound of the field's first
    block there (a superset of its cells): counting it as nothing would understate the
    bound, and the search would no longer be exact (blocks as large as the field did)."""
    n_rows, n_cols = bound.shape
    total = 0.0
    for k in range(cols.size):
        x, y = cols[k] + dx, rows[k] + dy
        if x < 0 < x + size:
            x = 0
        if y < 0 < y + size:
            y = 0
        if 0 <= x < n_cols and 0 <= y < n_rows:
            total += bound[y, x]
    return np.float64(np.float32(total))


@nb.njit(cache=True, nogil=True)
def _quarter_bounds(
    bound: FloatArray, cols: IntArray, rows: IntArray, dx: int, dy: int, half: int
) -> tuple[float, float, float, float]:
    """``_block_bound`` of the four ``half``-cell quarters of the block starting at (dx, dy)
    (at dx, dx + half; dy, dy + half), in one pass over the points: each quarter's sum is
    taken in the same order, so it equals ``_block_bound``'s to the bit."""
    n_rows, n_cols = bound.shape
    t00 = t10 = t01 = t11 = 0.0
    for k in range(cols.size):
        x0, y0 = cols[k] + dx, rows[k] + dy
        x1, y1 = x0 + half, y0 + half
        if x0 < 0 < x0 + half:
            x0 = 0
        if y0 < 0 < y0 + half:
            y0 = 0
        if x1 < 0 < x1 + half:
            x1 = 0
        if y1 < 0 < y1 + half:
            y1 = 0
        in_x0, in_x1 = 0 <= x0 < n_cols, 0 <= x1 < n_cols
        if 0 <= y0 < n_rows:
            if in_x0:
                t00 += bound[y0, x0]
            if in_x1:
                t10 += bound[y0, x1]
        if 0 <= y1 < n_rows:
            if in_x0:
                t01 += bound[y1, x0]
            if in_x1:
                t11 += bound[y1, x1]
    return (
        np.float64(np.float32(t00)),
        np.float64(np.float32(t10)),
        np.float64(np.float32(t01)),
        np.float64(np.float32(t11)),
    )


@nb.njit(cache=True, nogil=True)
def branch_and_bound(
    bounds: tuple[FloatArray, ...],
    px: F64,
    py: F64,
    cosines: F64,
    sines: F64,
    tx: float,
    ty: float,
    limit: int,
    turn_cost: F64,
    per_cell2: float,
    floor: float,
    cell_max: float,
    weak_x: float,
    weak_y: float,
    weak_cell2: float,
) -> tuple[int, int, int, float, int]:
    """The best rotation and translation within ``limit`` cells, by best-first search.

    Args:
        bounds: the field's sliding maxima over 2**L cells for L = 0 .. levels
            (``LikelihoodField.bound``); ``bounds[0]`` is the field.
        px, py: scan points in the robot frame, in cell units.
        cosines, sines: the rotations tried.
        tx, ty: the prior position in cells of the field.
        limit: translations dx, dy in [-limit, limit] cells are searched.
        turn_cost: per rotation, what its distance from the prior costs (summed-score units).
        per_cell2: what each squared cell of translation from the prior costs (same units).
        floor: the least summed field less pull wanted (-inf: none; the fields hold no
            NaN, whose blocks a floor would drop). A block whose bound
            falls below it cannot hold such a candidate and is dropped unexpanded: a search
            with nothing good enough in it ends early, and one with something finds the same
            optimum as without a floor.
        cell_max: the largest value a cell of the field can hold, so that ``cell_max`` times
            the points bounds every translation of a rotation not yet projected.
        weak_x, weak_y: a unit direction in the field (the scan's weak axis; anything when
            ``weak_cell2`` is 0).
        weak_cell2: what each squared cell of translation from the prior along that
            direction costs on top of ``per_cell2`` (same units).

    Returns:
        (rotation index, dx, dy, summed field under the points, blocks expanded) of the
        candidate with the highest summed field less its pull; the rotation index is -1 if
        there was nothing to search, or nothing reached ``floor``.

    A queue entry is (-(bound - pull), level, rotation, dx, dy, bound) for the 2^level x
    2^level block of translations starting at (dx, dy), the pull's two parts each taken at
    the block's translation least pulled by it (so their sum stays a bound); ties are
    broken by the rest of the tuple, so the result does not depend on the order blocks were
    queued in.

    A rotation starts as one entry bounded by ``cell_max`` per point less its turn cost, at
    the coarsest level and a dx before any block's (so it comes first among the entries it
    ties with exactly where its blocks would); only when it comes first are its points
    projected and its coarsest blocks queued. Under a strong pull toward the prior the
    rotations far from it are never projected: a tracked scan projects a few of its
    rotations instead of all of them.
    """
    levels = len(bounds) - 1
    top = 1 << levels
    n_angles, n_points = cosines.size, px.size
    cols = np.empty((n_angles, n_points), dtype=np.int64)
    rows = np.empty((n_angles, n_points), dtype=np.int64)
    queue = [(0.0, 0, 0, 0, 0, 0.0)]
    queue.pop()
    most = cell_max * n_points
    unprojected = -limit - 1  # the dx that marks a rotation's entry
    for a in range(n_angles):
        if most - turn_cost[a] >= floor:
            queue.append((turn_cost[a] - most, levels, a, unprojected, 0, most))
    heapq.heapify(queue)
    expanded = 0
    while len(queue) > 0:
        _, level, a, dx, dy, bound = heapq.heappop(queue)
        if dx == unprojected:  # a rotation's first turn: project its points, queue its blocks
            for k in range(n_points):
                cols[a, k], rows[a, k] = _project(px, py, cosines[a], sines[a], tx, ty, k)
            for dy in range(-limit, limit + 1, top):
                for dx in range(-limit, limit + 1, top):
                    bound = _block_bound(bounds[levels], cols[a], rows[a], dx, dy, top)
                    pull = turn_cost[a] + _pull(dx, dy, top, per_cell2, weak_x, weak_y, weak_cell2)
                    if bound - pull >= floor:
                        heapq.heappush(queue, (pull - bound, levels, a, dx, dy, bound))
            continue
        if level == 0:
            return a, dx, dy, bound, expanded
        expanded += 1
        half = 1 << (level - 1)
        quarters = _quarter_bounds(bounds[level - 1], cols[a], rows[a], dx, dy, half)
        for q in range(4):
            cx, cy = dx + half * (q & 1), dy + half * (q >> 1)
            if abs(cx) <= limit and abs(cy) <= limit:
                bound = quarters[q]
                pull = turn_cost[a] + _pull(cx, cy, half, per_cell2, weak_x, weak_y, weak_cell2)
                if bound - pull >= floor:
                    heapq.heappush(queue, (pull - bound, level - 1, a, cx, cy, bound))
    return -1, 0, 0, 0.0, expanded


@nb.njit(cache=True, nogil=True)
def best_among(
    bounds: tuple[FloatArray, ...],
    px: F64,
    py: F64,
    c: float,
    s: float,
    tx: float,
    ty: float,
    allowed: npt.NDArray[np.bool_],
) -> float:
    """The highest summed field under the points, rotated by (c, s), over the translations
    ``allowed`` marks: the same value as the largest of ``fine_scores`` over them.

    Args:
        bounds: the field's sliding maxima over 2**L cells for L = 0 .. levels
            (``LikelihoodField.bound``); ``bounds[0]`` is the field.
        px, py: scan points in the robot frame, in cell units.
        c, s: cosine and sine of the rotation.
        tx, ty: the pose's position in cells of the field.
        allowed: bool [2 * limit + 1, 2 * limit + 1], indexed [dy + limit, dx + limit]: the
            translations (dx, dy) [cells] taken.

    Returns:
        The best summed field (float32-rounded), 0.0 if ``allowed`` marks none.

    Blocks of translations are bounded by the summed sliding maximum and expanded
    best-first; a block with no allowed translation is dropped, so the first single
    translation taken off the queue is the best allowed one. A rival of a match lies outside
    a disc around it, where the field's peak is: most of the window is never scored.
    """
    levels = len(bounds) - 1
    top = 1 << levels
    limit = (allowed.shape[0] - 1) // 2
    n = allowed.shape[0]
    # Summed-area table of the mask: whether a block holds an allowed translation, in O(1).
    area = np.zeros((n + 1, n + 1), dtype=np.int64)
    for j in range(n):
        for i in range(n):
            area[j + 1, i + 1] = area[j, i + 1] + area[j + 1, i] - area[j, i] + allowed[j, i]
    cols = np.empty(px.size, dtype=np.int64)
    rows = np.empty(px.size, dtype=np.int64)
    for k in range(px.size):
        cols[k], rows[k] = _project(px, py, c, s, tx, ty, k)
    queue = [(0.0, 0, 0, 0)]
    queue.pop()
    for dy in range(-limit, limit + 1, top):
        for dx in range(-limit, limit + 1, top):
            if _holds(area, dx + limit, dy + limit, top):
                bound = _block_bound(bounds[levels], cols, rows, dx, dy, top)
                queue.append((-bound, levels, dx, dy))
    heapq.heapify(queue)
    while len(queue) > 0:
        negative, level, dx, dy = heapq.heappop(queue)
        if level == 0:
            return -negative
        half = 1 << (level - 1)
        quarters = _quarter_bounds(bounds[level - 1], cols, rows, dx, dy, half)
        for q in range(4):
            cx, cy = dx + half * (q & 1), dy + half * (q >> 1)
            if cx <= limit and cy <= limit and _holds(area, cx + limit, cy + limit, half):
                heapq.heappush(queue, (-quarters[q], level - 1, cx, cy))
    return 0.0


@nb.njit(cache=True, nogil=True, inline="always")
def _holds(area: IntArray, i0: int, j0: int, size: int) -> bool:
    """True if the size x size block of the mask starting at column i0, row j0 (clipped)
    holds a marked cell; ``area`` is the mask's summed-area table."""
    n = area.shape[0] - 1
    i1, j1 = min(i0 + size, n), min(j0 + size, n)
    return bool(area[j1, i1] - area[j0, i1] - area[j1, i0] + area[j0, i0] > 0)


@nb.njit(cache=True, nogil=True, inline="always")
def _pull(
    dx: int, dy: int, size: int, per_cell2: float, weak_x: float, weak_y: float, weak_cell2: float
) -> float:
    """A lower bound of the translation pull over the size x size block starting at (dx, dy):
    ``per_cell2`` per squared cell from the prior plus ``weak_cell2`` per squared cell along
    the unit direction (weak_x, weak_y), each part taken at its own least over the block (so
    the sum is at most the pull of any translation in it)."""
    pull = per_cell2 * _nearest2(dx, dy, size)
    if weak_cell2 > 0.0:
        pull += weak_cell2 * _nearest_along2(dx, dy, size, weak_x, weak_y)
    return pull


@nb.njit(cache=True, nogil=True, inline="always")
def _nearest_along2(dx: int, dy: int, size: int, ux: float, uy: float) -> float:
    """A lower bound [cells^2] of the squared distance along the unit direction (ux, uy)
    from the prior (0, 0) to the translations of the size x size block starting at
    (dx, dy): the least over the block's rectangle, 0 if the rectangle straddles the line
    through the prior across that direction. (The distance along it is linear, so its
    least and most over the rectangle lie at corners.)"""
    x1, y1 = dx + size - 1, dy + size - 1
    c00, c10 = ux * dx + uy * dy, ux * x1 + uy * dy
    c01, c11 = ux * dx + uy * y1, ux * x1 + uy * y1
    low = min(c00, c10, c01, c11)
    high = max(c00, c10, c01, c11)
    if low <= 0.0 <= high:
        return 0.0
    nearest = min(abs(low), abs(high))
    return nearest * nearest


@nb.njit(cache=True, nogil=True, inline="always")
def _nearest2(dx: int, dy: int, size: int) -> float:
    """Squared distance [cells^2] from the prior (0, 0) to the nearest translation of the
    size x size block starting at (dx, dy)."""
    nx = min(max(0, dx), dx + size - 1)
    ny = min(max(0, dy), dy + size - 1)
    return float(nx * nx + ny * ny)


@nb.njit(cache=True, nogil=True)
def fine_scores(
    field: FloatArray,
    px: F64,
    py: F64,
    c: float,
    s: float,
    tx: float,
    ty: float,
    dx0: int,
    dy0: int,
    nx: int,
    ny: int,
) -> FloatArray:
    """Exact scores of translations dx0..dx0+nx-1, dy0..dy0+ny-1 for one rotation.

    Returns:
        float32[ny, nx]: summed field under the points, indexed [dy - dy0, dx - dx0].
    """
    n_rows, n_cols = field.shape
    cols = np.empty(px.size, dtype=np.int64)
    rows = np.empty(px.size, dtype=np.int64)
    for k in range(px.size):
        cols[k], rows[k] = _project(px, py, c, s, tx, ty, k)
    out = np.zeros((ny, nx), dtype=np.float32)
    for j in range(ny):
        for i in range(nx):
            total = 0.0
            for k in range(px.size):
                x, y = cols[k] + dx0 + i, rows[k] + dy0 + j
                if 0 <= x < n_cols and 0 <= y < n_rows:
                    total += field[y, x]
            out[j, i] = total
    return out


@nb.njit(cache=True, nogil=True)
def count_known(
    index: I32Grid,
    tiles: Tiles,
    used: IntArray,
    off_r: int,
    off_c: int,
    rows: int,
    cols: int,
    cols_x: IntArray,
    rows_y: IntArray,
) -> int:
    """How many of the cells (cols_x[i], rows_y[i]) have an observed cell (log-odds not 0)
    among themselves and their 8 neighbours; cells off the grid count as unobserved. The
    grid is the tiled array of the first seven arguments (TiledArray.parts)."""
    known = 0
    for i in range(cols_x.size):
        x0 = cols_x[i]
        y0 = rows_y[i]
        found = False
        for y in range(max(y0 - 1, 0), min(y0 + 2, rows)):
            for x in range(max(x0 - 1, 0), min(x0 + 2, cols)):
                if _read(index, tiles, y + off_r, x + off_c) != 0.0:
                    found = True
                    break
            if found:
                break
        if found:
            known += 1
    return known
