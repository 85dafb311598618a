"""NumPy twins of navd.slam._grid_kernels, written from the definitions, loops kept plain."""

from __future__ import annotations

import heapq

import numpy as np


def line_cells(x0: int, y0: int, x1: int, y1: int) -> list[tuple[int, int]]:
    """Cells from (x0, y0) to (x1, y1), end excluded: a digital line by sampling."""
    n = max(abs(x1 - x0), abs(y1 - y0))
    cells = []
    for i in range(n):
        t = i / n
        cells.append((round(x0 + t * (x1 - x0)), round(y0 + t * (y1 - y0))))
    return cells


def ray_update(logodds, x0, y0, ends_x, ends_y, hits, l_free, l_occ, l_min, l_max, keep=0):  # type: ignore[no-untyped-def]
    rows, cols = logodds.shape
    for x1, y1, hit in zip(ends_x, ends_y, hits, strict=True):
        for x, y in line_cells(x0, y0, int(x1), int(y1)):
            if hit and max(abs(int(x1) - x), abs(int(y1) - y)) <= keep:
                continue  # a hit's ray leaves the cells within ``keep`` of its end alone
            if 0 <= x < cols and 0 <= y < rows:
                logodds[y, x] = max(logodds[y, x] + l_free, l_min)
        if hit and 0 <= x1 < cols and 0 <= y1 < rows:
            logodds[y1, x1] = min(logodds[y1, x1] + l_occ, l_max)


def smear(logodds, threshold, row0, col0, kernel, shape):  # type: ignore[no-untyped-def]
    field = np.zeros(shape, dtype=np.float32)
    r = kernel.shape[0] // 2
    for fy in range(shape[0]):
        for fx in range(shape[1]):
            gy, gx = fy + row0, fx + col0
            if not (0 <= gy < logodds.shape[0] and 0 <= gx < logodds.shape[1]):
                continue
            if logodds[gy, gx] <= threshold:
                continue
            ys = slice(max(fy - r, 0), min(fy + r + 1, shape[0]))
            xs = slice(max(fx - r, 0), min(fx + r + 1, shape[1]))
            k = kernel[ys.start - fy + r : ys.stop - fy + r, xs.start - fx + r : xs.stop - fx + r]
            field[ys, xs] = np.maximum(field[ys, xs], k)
    return field


def sliding_max(field, f):  # type: ignore[no-untyped-def]
    out = np.empty_like(field)
    for v in range(field.shape[0]):
        for u in range(field.shape[1]):
            out[v, u] = field[v : v + f, u : u + f].max()
    return out


def score(field, px, py, c, s, tx, ty, dx, dy, size=1):  # type: ignore[no-untyped-def]
    cols = np.floor(c * px - s * py + tx + 0.5).astype(int) + dx
    rows = np.floor(s * px + c * py + ty + 0.5).astype(int) + dy
    # a block of `size` cells starting before the field but reaching into it: its first cell
    cols = np.where((cols < 0) & (cols + size > 0), 0, cols)
    rows = np.where((rows < 0) & (rows + size > 0), 0, rows)
    inside = (cols >= 0) & (cols < field.shape[1]) & (rows >= 0) & (rows < field.shape[0])
    return float(field[rows[inside], cols[inside]].sum())


def best_among(field, px, py, c, s, tx, ty, allowed):  # type: ignore[no-untyped-def]
    """The best score over the translations ``allowed`` marks (0.0 if none)."""
    limit = (allowed.shape[0] - 1) // 2
    scores = [
        score(field, px, py, c, s, tx, ty, dx - limit, dy - limit)
        for dy, dx in zip(*np.nonzero(allowed), strict=True)
    ]
    return max(scores, default=0.0)


def extent(points, x, y):  # type: ignore[no-untyped-def]
    every = np.vstack([points, [[x, y]]])
    if not np.isfinite(every).all():
        return (np.nan,) * 4
    return (*every.min(axis=0), *every.max(axis=0))


def cells_and_box(points, origin_x, origin_y, res, col, row):  # type: ignore[no-untyped-def]
    cells = np.floor((points - np.array([origin_x, origin_y])) / res).astype(np.int64)
    every = np.vstack([cells, [[col, row]]])
    return (
        cells[:, 0],
        cells[:, 1],
        every[:, 0].min(),
        every[:, 0].max(),
        every[:, 1].min(),
        every[:, 1].max(),
    )


def count_known(logodds, cols_x, rows_y):  # type: ignore[no-untyped-def]
    padded = np.pad(logodds != 0.0, 1)  # off the grid: unobserved
    count = 0
    for x, y in zip(cols_x, rows_y, strict=True):
        if -1 <= x <= logodds.shape[1] and -1 <= y <= logodds.shape[0]:
            count += bool(padded[max(y, 0) : y + 3, max(x, 0) : x + 3].any())
    return count


def branch_and_bound(bounds, px, py, angles, tx, ty, limit):  # type: ignore[no-untyped-def]
    """Best-first search over blocks of translations; bounds[L] bounds 2^L x 2^L blocks."""
    levels = len(bounds) - 1

    def block(level, a, dx, dy):  # type: ignore[no-untyped-def]
        c, s = np.cos(angles[a]), np.sin(angles[a])
        return score(bounds[level], px, py, c, s, tx, ty, dx, dy, 2**level)

    starts = range(-limit, limit + 1, 2**levels)
    queue = [
        (-block(levels, a, dx, dy), levels, a, dx, dy)
        for a in range(len(angles))
        for dy in starts
        for dx in starts
    ]
    heapq.heapify(queue)
    while queue:
        negative, level, a, dx, dy = heapq.heappop(queue)
        if level == 0:
            return a, dx, dy, -negative
        half = 2 ** (level - 1)
        for cx, cy in ((dx, dy), (dx + half, dy), (dx, dy + half), (dx + half, dy + half)):
            if abs(cx) <= limit and abs(cy) <= limit:
                heapq.heappush(queue, (-block(level - 1, a, cx, cy), level - 1, a, cx, cy))
    return -1, 0, 0, 0.0
