"""Numba kernel of A* on a weighted 8-connected costmap, with its open list in buckets.

The graph and the step costs are those of ``_astar_kernels``: a step of length L cells (1 or
sqrt 2) from a to b costs L * (1 + w * (c_a + c_b) / 2), a diagonal only between two free
cells, the heuristic is the octile distance. What differs is the open list. A binary or 4-ary
heap costs a few dozen ns per push and pop on the daemon's grids (tens of thousands of open
cells), more than the rest of an expansion. Here the key g + h is cut into buckets of 1 /
``buckets_per_cell`` of a cell (Dial's bucket queue, in a ring: a key grows by at most one
step's cost plus sqrt 2 from the key it was reached from, or by a bounded amount along a pass,
below, so only the ring's buckets are ever in use). A bucket is a doubly linked list threaded
through the cells themselves: pushing, popping and moving an improved open cell to its new
bucket are a few array writes, and a cell is open at most once (no stale copies). Within a
bucket the newest cell comes first, which breaks near-ties towards the cell nearer the goal.

Where a cell and its 8 neighbours are all free floor (cost 0), a step costs its length alone
and the search prunes as jump point search does: a cell entered straight passes the search on
straight ahead only, one entered diagonally along the diagonal and its two components; every
other neighbour is reached at least as cheaply from the cell before. Near anything costly or
blocked every neighbour is tried. A straight step onto such a cell does not put it in a bucket:
it is passed over at once (its g and direction written as if it had been expanded, prev_open -1
for "in no bucket"), and so is the next, until the pass meets the goal, a cell on the grid's
border or not open floor, or has used up its room in the ring (below): that cell goes in a
bucket. A closed cell, or one already reached at no higher cost, ends the pass before it and is
left as it is. A cell passed over and later reached more cheaply goes in a bucket then, as any
improved cell. This is jump point search's straight jump, with the cells on the way recorded so
that a later ray at no lower cost stops where an earlier one went (docs/planning.md gives
what the passes saved).

The price of the buckets is order within a bucket: a cell may be expanded before one whose
key is lower by less than a bucket's width d = 1 / buckets_per_cell. Each such slip adds at
most d to the cost of what it closes, and slips only add up along a route's cells, each step
of which costs at least 1: the route found costs at most (1 + d) * C + d, with C the optimal
cost (256 buckets per cell: within 0.4 % of optimal). A pass adds no slip of its own: it
writes g ahead of cells with lower keys, but a cell passed over stays open to a cheaper
arrival, which puts it in a bucket in key order; only the cells taken out of buckets are
closed. Tests check the bound against Dijkstra's algorithm.

The ring is sized for one step's growth of the key plus PASS_ROOM_CELLS, the room a pass
along floor has: a straight step raises the key by at most 2 cells, so a pass stops where the
cell it ends on would still fit (15 cells on at least, at 256 buckets a cell). It is sized
for costs up to a ceiling, COST_CEILING (the costmap's scale) unless told otherwise; meeting
a costlier cell ends the search with CEILING_TOO_LOW, and the caller searches again with the
grid's highest cost.

Working arrays are passed in and stamped with a generation number, so a planner reuses them
between searches without clearing millions of cells each time (20 bytes a cell).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from navd.planning._astar_kernels import _DC, _DR, _LEN, CLOSED, octile

__all__ = ["BUCKETS_PER_CELL", "CEILING_TOO_LOW", "COST_CEILING", "bucket_astar", "trace_steps"]

BUCKETS_PER_CELL = 256
COST_CEILING = 1.0  # highest cell cost of the costmap's scale
PASS_ROOM_CELLS = 32.0  # [cells of key] room in the ring beyond one step, for passes
CEILING_TOO_LOW = -2.0
_NONE = -1
_SQRT2 = math.sqrt(2.0)
_NO_SIGN = 0x7FFFFFFF


def _natural_directions() -> npt.NDArray[np.int64]:
    """By the step k that entered a cell, the directions worth following from it when its
    3 x 3 block is all free floor (jump point search's natural neighbours): straight on, or
    the diagonal and its two components. Every other neighbour is reached at least as
    cheaply from the cell before, without passing here."""
    masks = []
    for k in range(8):
        dr, dc = int(_DR[k]), int(_DC[k])
        if k < 4:
            masks.append(1 << k)
        else:
            along_rows = next(j for j in range(4) if (_DR[j], _DC[j]) == (dr, 0))
            along_cols = next(j for j in range(4) if (_DR[j], _DC[j]) == (0, dc))
            masks.append(1 << k | 1 << along_rows | 1 << along_cols)
    return np.array(masks, dtype=np.int64)


_NATURAL = _natural_directions()

Int32Array = npt.NDArray[np.int32]


@njit(cache=True, nogil=True, inline="always")
def _row(node: int, cols: int, per_col: float) -> int:
    """node // cols by a multiplication (an integer division costs tens of cycles, twice
    per expansion): the float estimate is off by at most one, either way."""
    r = int(node * per_col)
    if r * cols > node:
        r -= 1
    elif (r + 1) * cols <= node:
        r += 1
    return r


@njit(cache=True, nogil=True, inline="always")
def _open_floor(bits: npt.NDArray[np.uint32], node: int, cols: int) -> bool:
    """Whether an inner cell and its 8 neighbours all cost zero, read as the float32 costs'
    bit patterns: the nine words ORed together with the sign bit masked off (-0.0 is floor
    too), one test instead of eight tests of finiteness and zero (a sixth of the search's
    time on the daemon's grids, where most cells expanded are floor)."""
    up = node - cols
    down = node + cols
    either = bits[up - 1] | bits[up] | bits[up + 1] | bits[node - 1] | bits[node]
    either |= bits[node + 1] | bits[down - 1] | bits[down] | bits[down + 1]
    return bool(either & _NO_SIGN == 0)


@njit(cache=True, nogil=True, inline="always")
def _unlink(head: Int32Array, next_open: Int32Array, prev_open: Int32Array, cell: int) -> None:
    """Take an open cell out of its bucket's list."""
    before = prev_open[cell]
    later = next_open[cell]
    if before < _NONE:
        head[-2 - before] = later
    else:
        next_open[before] = later
    if later != _NONE:
        prev_open[later] = before


@njit(cache=True, nogil=True)
def bucket_astar(
    cost: npt.NDArray[np.float32],
    start: int,
    goal: int,
    cost_weight: float,
    g: npt.NDArray[np.float64],
    mark: Int32Array,
    next_open: Int32Array,
    prev_open: Int32Array,
    generation: int,
    buckets_per_cell: float,
    cost_ceiling: float,
) -> tuple[float, int]:
    """A* from cell ``start`` to cell ``goal`` (flat indices row * cols + col).

    Args:
        cost: rows x cols float32 cell costs (>= 0), inf where blocked, C-contiguous.
        start, goal: flat cell indices, both with finite cost.
        cost_weight: w in the step cost.
        g, mark: working arrays of rows * cols entries; ``g`` (route cost in cells) is valid
            where ``mark >> 4 == generation``, and ``mark & 7`` is the direction of the step
            that entered the cell (read the route back with ``trace_steps``).
        next_open, prev_open: working arrays of rows * cols entries: the bucket lists
            (``prev_open`` below -1 marks a bucket's first cell: -2 - the bucket's slot; -1
            a cell reached, open, and in no bucket: passed over).
        generation: a number in 1..MAX_GENERATION not used by an earlier search with these
            arrays.
        buckets_per_cell: buckets per cell of key (d = 1 / buckets_per_cell above).
        cost_ceiling: the highest cell cost the ring of buckets is sized for.

    Returns:
        (cost of the route in cells of length, -1 if none, CEILING_TOO_LOW if a cell costs
        more than ``cost_ceiling``: search again with a higher one and a new generation;
        cells expanded, that is taken out of buckets: cells passed over do not count).

    """
    rows, cols = cost.shape
    if cost.itemsize != 4:
        raise ValueError("bucket_astar reads float32 costs (their bit patterns)")
    flat = cost.ravel()
    bits = flat.view(np.uint32)
    goal_r = goal // cols
    goal_c = goal % cols
    per_col = 1.0 / cols
    offsets = _DR * cols + _DC
    tag = generation << 4
    reach = (_SQRT2 * (1.0 + cost_weight * cost_ceiling) + _SQRT2) * buckets_per_cell + 2.0
    reach += PASS_ROOM_CELLS * buckets_per_cell
    per_pass = math.ceil(2.0 * buckets_per_cell) + 1  # [buckets] most a step along floor adds
    ring = 1
    while ring < reach:
        ring *= 2
    mask = ring - 1
    head = np.full(ring, _NONE, dtype=np.int32)
    if flat[start] > cost_ceiling:  # its steps could outrun the ring like any costly cell's
        return CEILING_TOO_LOW, 0
    g[start] = 0.0
    mark[start] = tag
    current = int(octile(start // cols - goal_r, start % cols - goal_c) * buckets_per_cell)
    head[current & mask] = start
    next_open[start] = _NONE
    prev_open[start] = -2 - (current & mask)
    open_cells = 1
    expanded = 0
    while open_cells > 0:
        node = head[current & mask]
        while node == _NONE:
            current += 1
            node = head[current & mask]
        after = next_open[node]
        head[current & mask] = after
        if after != _NONE:
            prev_open[after] = -2 - (current & mask)
        open_cells -= 1
        mark[node] |= CLOSED
        expanded += 1
        if node == goal:
            return g[node], expanded
        r = _row(node, cols, per_col)
        c = node - r * cols
        g_here = g[node]
        c_here = flat[node]
        border = r == 0 or c == 0 or r == rows - 1 or c == cols - 1
        free = 0  # bit k: the neighbour k is on the grid and free
        floor = 0  # bit k: and costs nothing
        if not border and _open_floor(bits, node, cols):
            free = floor = 0xFF  # nine cells of floor, told at once
        else:
            for k in range(8):
                if border and not (0 <= r + _DR[k] < rows and 0 <= c + _DC[k] < cols):
                    continue
                v = flat[node + offsets[k]]
                if math.isfinite(v):
                    free |= 1 << k
                    if v == 0.0:
                        floor |= 1 << k
        if c_here == 0.0 and floor == 0xFF and node != start:
            follow = _NATURAL[mark[node] & 7]  # open floor: steps are lengths, prune as JPS
        else:
            follow = free
        for k in range(8):
            if not follow >> k & 1:
                continue
            dr = _DR[k]
            dc = _DC[k]
            # A diagonal needs both straight cells beside it free: (dr, 0) is k 0 or 1,
            # (0, dc) is k 2 or 3.
            if k >= 4 and not (free >> ((dr + 1) >> 1) & 1 and free >> (2 + ((dc + 1) >> 1)) & 1):
                continue
            nxt = node + offsets[k]
            m_next = mark[nxt]
            seen = (m_next >> 4) == generation
            if seen and m_next & CLOSED:
                continue
            c_next = flat[nxt]
            if c_next > cost_ceiling:
                return CEILING_TOO_LOW, expanded
            g_next = g_here + _LEN[k] * (1.0 + cost_weight * 0.5 * (c_here + c_next))
            if seen and g_next >= g[nxt]:
                continue
            nr = r + dr
            nc = c + dc
            bucket = int((g_next + octile(nr - goal_r, nc - goal_c)) * buckets_per_cell)
            if (
                k < 4
                and bucket <= current + ring - 2 - per_pass  # room for one step at least
                and nxt != goal
                and 0 < nr < rows - 1
                and 0 < nc < cols - 1
                and _open_floor(bits, nxt, cols)
            ):
                # Straight onto open floor: the cell would pass the search on straight ahead
                # only, so it is passed over now, its g and direction kept as if expanded
                # (in no bucket: prev_open -1), and so is the next, until the goal, a border
                # cell, one not open floor, one reached at no higher cost before, or the end
                # of the room: each step costs 1 and raises the key by at most 2 cells, and
                # ``passes`` keeps the key of the cell the pass ends on inside the ring.
                passes = (current + ring - 2 - bucket) // per_pass
                step = offsets[k]
                side = cols if dr == 0 else 1  # across the pass: the next block's new cells
                dominated = False
                while True:
                    if seen and prev_open[nxt] != _NONE:
                        _unlink(head, next_open, prev_open, nxt)
                        open_cells -= 1
                    g[nxt] = g_next
                    mark[nxt] = tag | k
                    prev_open[nxt] = _NONE
                    nxt += step
                    nr += dr
                    nc += dc
                    g_next += 1.0
                    passes -= 1
                    m_next = mark[nxt]
                    seen = (m_next >> 4) == generation
                    if seen and (m_next & CLOSED or g_next >= g[nxt]):
                        dominated = True
                        break
                    if passes == 0 or nxt == goal or not (0 < nr < rows - 1 and 0 < nc < cols - 1):
                        break
                    # The cell before was open floor: only the three cells ahead are new.
                    ahead = nxt + step
                    if (bits[ahead - side] | bits[ahead] | bits[ahead + side]) & _NO_SIGN:
                        break
                if dominated:
                    continue
                bucket = int((g_next + octile(nr - goal_r, nc - goal_c)) * buckets_per_cell)
            if seen and prev_open[nxt] != _NONE:
                # Improved while open: out of its bucket, into the new one below.
                _unlink(head, next_open, prev_open, nxt)
                open_cells -= 1
            g[nxt] = g_next
            mark[nxt] = tag | k
            slot = max(bucket, current) & mask
            first = head[slot]
            next_open[nxt] = first
            prev_open[nxt] = -2 - slot
            if first != _NONE:
                prev_open[first] = nxt
            head[slot] = nxt
            open_cells += 1
    return -1.0, expanded


@njit(cache=True, nogil=True)
def trace_steps(mark: Int32Array, start: int, goal: int, cols: int) -> npt.NDArray[np.int64]:
    """The (row, col) cells from ``start`` to ``goal``, walked back along the direction each
    cell was entered by (``mark & 7``, as ``bucket_astar`` leaves it)."""
    offsets = _DR * cols + _DC
    count = 1
    node = goal
    while node != start:
        node -= offsets[mark[node] & 7]
        count += 1
    cells = np.empty((count, 2), dtype=np.int64)
    node = goal
    for i in range(count - 1, -1, -1):
        cells[i, 0] = node // cols
        cells[i, 1] = node % cols
        if i > 0:
            node -= offsets[mark[node] & 7]
    return cells
