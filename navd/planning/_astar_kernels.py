"""Numba kernel of A* on a uniform 8-connected grid, by jump point search.

The graph: every cell with a finite cost is a node; a cell joins its 8 neighbours, a diagonal
step only when both cells it passes between are free too (no squeezing between two blocked
cells that touch at a corner). A step of length L cells (1 or sqrt 2) from a to b costs

    L * (1 + w * (c_a + c_b) / 2)

with c the cell costs and w the cost weight, so a route pays for running close to walls. The
heuristic is the octile distance (the exact length of the shortest 8-connected route with no
costs): admissible and consistent, so the first time the goal is popped its cost is optimal.

This module searches the uniform grid, where every step costs its length alone (w = 0, or
every free cell of cost 0: the grid pyastar2d and most benchmarks search); grids with cell
costs are searched by ``_bucket_kernels``, on the same graph. The search jumps (jump point
search, Harabor and Grastien, AAAI 2011, in the variant that never cuts a corner): from a cell
it follows only the directions no other route serves as cheaply, and runs straight or
diagonally to the next cell where a shortest route could turn (a jump point) instead of
queueing every cell on the way. Straight runs are read 64 cells at a time from packed bit
sets (``_bitgrid_kernels``). On a 25 %-blocked 2000 x 2000 grid about a thousand cells are
expanded instead of 700 000. Ties in f go to the node nearer the goal (fewer expansions): the
open list is ordered by g + h * (1 + 1e-9), which keeps the route within a relative 1e-9 of
optimal. (Jumping only across the zero-cost floor between inflated bands of a weighted grid
was tried, stayed exact, and was slower: every diagonal run that sees a band must stop there,
so nearly every cell became a jump point.)

Working arrays are passed in and stamped with a generation number, so a planner reuses them
between searches without clearing millions of cells each time.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from navd.planning._bitgrid_kernels import bit_of, scan_backward, scan_forward

__all__ = [
    "MAX_GENERATION",
    "jump_point_search",
    "octile",
    "path_changed",
    "route_costs_to_goal",
    "segment_changed",
    "segment_max_cost",
    "shortcut",
    "trace_back",
    "uniform_costs",
]

SQRT2 = math.sqrt(2.0)

FloatArray = npt.NDArray[np.float64]
Int32Array = npt.NDArray[np.int32]
WordArray = npt.NDArray[np.uint64]

# Neighbour offsets (row, col) and step lengths [cells].
_DR = np.array([-1, 1, 0, 0, -1, -1, 1, 1], dtype=np.int64)
_DC = np.array([0, 0, -1, 1, -1, 1, -1, 1], dtype=np.int64)
TIE = 1.0 + 1e-9  # heuristic scale that breaks f ties towards the goal
_LEN = np.array([1.0, 1.0, 1.0, 1.0, SQRT2, SQRT2, SQRT2, SQRT2])
# k of the step (dr, dc), at (dr + 1) * 3 + dc + 1 (the centre has none).
_DIRECTION = np.array([4, 0, 5, 2, -1, 3, 6, 1, 7], dtype=np.int64)


@njit(cache=True, nogil=True, inline="always")
def octile(dr: int, dc: int) -> float:
    """Length [cells] of the shortest 8-connected route over (dr, dc) free cells."""
    a = abs(dr)
    b = abs(dc)
    if a < b:
        a, b = b, a
    return (a - b) + SQRT2 * b


# The open list is a 4-ary min-heap of (key, node) in two arrays: shallower than a binary
# heap, and a node's four children share a cache line. A cell improved while open is pushed
# again; the stale entry is skipped when it comes up.
@njit(cache=True, nogil=True)
def _push(keys: FloatArray, nodes: Int32Array, size: int, key: float, node: int) -> None:
    i = size
    while i > 0:
        up = (i - 1) >> 2
        if keys[up] <= key:
            break
        keys[i] = keys[up]
        nodes[i] = nodes[up]
        i = up
    keys[i] = key
    nodes[i] = node


@njit(cache=True, nogil=True)
def _pop(keys: FloatArray, nodes: Int32Array, size: int) -> int:
    """Remove the root of a heap of ``size`` entries; return its node."""
    top = nodes[0]
    last = size - 1
    key = keys[last]
    node = nodes[last]
    i = 0
    while True:
        first = 4 * i + 1
        if first >= last:
            break
        best = first
        best_key = keys[first]
        for child in range(first + 1, min(first + 4, last)):
            if keys[child] < best_key:
                best_key = keys[child]
                best = child
        if best_key >= key:
            break
        keys[i] = best_key
        nodes[i] = nodes[best]
        i = best
    keys[i] = key
    nodes[i] = node
    return int(top)


# A cell's mark packs generation << 4 | closed (8) | the direction k (0..7) of the last step
# into it, so one 4-byte read tells whether it was seen in this search, whether it is closed,
# and from which side it was entered; g and the cell it was reached from live beside it.
CLOSED = 8
MAX_GENERATION = (1 << 27) - 1
NO_JUMP = -1


@njit(cache=True, nogil=True, inline="always")
def _cell(lines: WordArray, r: int, c: int) -> bool:
    """Bit (r, c) of a row-line bit set (r from -1 to rows, c from -1 to cols)."""
    return bit_of(lines[r + 1], c + 1)


@njit(cache=True, nogil=True, inline="always")
def _jump_straight(
    rows_free: WordArray,
    cols_free: WordArray,
    r: int,
    c: int,
    dr: int,
    dc: int,
    goal_r: int,
    goal_c: int,
) -> int:
    """Steps from (r, c) along (dr, dc) (one of them 0) to the next jump point, or NO_JUMP.

    A jump point is the goal or a cell with a forced neighbour: a free side cell whose cell
    behind is blocked, so the only shortest way to it passes here.
    """
    if dr == 0:
        free, side_a, side_b = rows_free[r + 1], rows_free[r], rows_free[r + 2]
        here, step, on_line, goal_at = c + 1, dc, goal_r == r, goal_c + 1
    else:
        free, side_a, side_b = cols_free[c + 1], cols_free[c], cols_free[c + 2]
        here, step, on_line, goal_at = r + 1, dr, goal_c == c, goal_r + 1
    if step > 0:
        stop = scan_forward(free, side_a, side_b, here + 1)
    else:
        stop = scan_backward(free, side_a, side_b, here - 1)
    if on_line and (goal_at - here) * step > 0 and (stop - goal_at) * step >= 0:
        return (goal_at - here) * step
    if not bit_of(free, stop):
        return NO_JUMP
    return (stop - here) * step


@njit(cache=True, nogil=True, inline="always")
def _jump_diagonal(
    rows_free: WordArray,
    cols_free: WordArray,
    r: int,
    c: int,
    dr: int,
    dc: int,
    goal_r: int,
    goal_c: int,
) -> int:
    """Diagonal steps from (r, c) along (dr, dc) to the next jump point, or NO_JUMP: the goal,
    or a cell from which a straight jump along either component finds one. (With no squeezing
    past corners a diagonal move has no forced neighbours of its own.)"""
    n = 0
    while True:
        if not (_cell(rows_free, r + dr, c) and _cell(rows_free, r, c + dc)):
            return NO_JUMP
        r += dr
        c += dc
        n += 1
        if not _cell(rows_free, r, c):
            return NO_JUMP
        if r == goal_r and c == goal_c:
            return n
        if (
            _jump_straight(rows_free, cols_free, r, c, dr, 0, goal_r, goal_c) != NO_JUMP
            or _jump_straight(rows_free, cols_free, r, c, 0, dc, goal_r, goal_c) != NO_JUMP
        ):
            return n


@njit(cache=True, nogil=True, inline="always")
def _direction(dr: int, dc: int) -> int:
    """The index k of the step (dr, dc) in _DR, _DC."""
    return int(_DIRECTION[(dr + 1) * 3 + dc + 1])


@njit(cache=True, nogil=True, inline="always")
def _pruned_directions(rows_free: WordArray, r: int, c: int, k: int) -> int:
    """Bit mask of the directions worth following from (r, c) entered by step k: every other
    neighbour is reached at least as cheaply without passing here."""
    dr = _DR[k]
    dc = _DC[k]
    if k >= 4:
        return 1 << k | 1 << _direction(dr, 0) | 1 << _direction(0, dc)
    mask = 1 << k
    for side in (-1, 1):
        if dr == 0:
            if _cell(rows_free, r + side, c) and not _cell(rows_free, r + side, c - dc):
                mask |= 1 << _direction(side, 0) | 1 << _direction(side, dc)
        elif _cell(rows_free, r, c + side) and not _cell(rows_free, r - dr, c + side):
            mask |= 1 << _direction(0, side) | 1 << _direction(dr, side)
    return mask


@njit(cache=True, nogil=True)
def jump_point_search(
    cols: int,
    start: int,
    goal: int,
    g: FloatArray,
    mark: Int32Array,
    parent: Int32Array,
    generation: int,
    rows_free: WordArray,
    cols_free: WordArray,
) -> tuple[float, int]:
    """A* by jump point search from cell ``start`` to cell ``goal`` (flat indices
    row * cols + col) of a uniform grid.

    Args:
        cols: the grid's width [cells].
        start, goal: flat cell indices, both free.
        g, mark, parent: working arrays of rows * cols entries (see CLOSED); ``g`` and
            ``parent`` (the cell a jump came from) are valid where
            ``mark >> 4 == generation``. Read the route back with ``trace_back``.
        generation: a number in 1..MAX_GENERATION not used by an earlier search with these
            arrays.
        rows_free, cols_free: the grid's free cells packed by ``pack_free_cells``.

    Returns:
        (cost of the best route in cells of length, -1 if none; jump points expanded).
    """
    goal_r = goal // cols
    goal_c = goal % cols
    offsets = _DR * cols + _DC
    seen_tag = generation << 4
    capacity = 1024
    keys = np.empty(capacity)
    nodes = np.empty(capacity, dtype=np.int32)
    size = 0
    # Successors whose key is no larger than the key last taken from the heap are already
    # minimal: they go on a stack and are expanded before the heap is touched again.
    stack = np.empty(capacity, dtype=np.int32)
    stack_size = 0
    current_key = -math.inf
    g[start] = 0.0
    mark[start] = seen_tag
    parent[start] = start
    _push(keys, nodes, size, octile(start // cols - goal_r, start % cols - goal_c) * TIE, start)
    size += 1
    expanded = 0
    while size > 0 or stack_size > 0:
        if stack_size > 0:
            stack_size -= 1
            node = stack[stack_size]
        else:
            current_key = keys[0]
            node = _pop(keys, nodes, size)
            size -= 1
        m = mark[node]
        if m & CLOSED:
            continue  # a stale duplicate: this cell was expanded at a lower cost already
        mark[node] = m | CLOSED
        expanded += 1
        if node == goal:
            return g[node], expanded
        r = node // cols
        c = node % cols
        g_here = g[node]
        directions = 0xFF if node == start else _pruned_directions(rows_free, r, c, m & 7)
        for k in range(8):
            if not directions & (1 << k):
                continue
            dr = _DR[k]
            dc = _DC[k]
            if k < 4:
                steps = _jump_straight(rows_free, cols_free, r, c, dr, dc, goal_r, goal_c)
            else:
                steps = _jump_diagonal(rows_free, cols_free, r, c, dr, dc, goal_r, goal_c)
            if steps == NO_JUMP:
                continue
            nxt = node + steps * offsets[k]
            m_next = mark[nxt]
            seen = (m_next >> 4) == generation
            if seen and m_next & CLOSED:
                continue
            g_next = g_here + steps * _LEN[k]
            if seen and g_next >= g[nxt]:
                continue
            g[nxt] = g_next
            mark[nxt] = seen_tag | k
            parent[nxt] = node
            key = g_next + octile(r + steps * dr - goal_r, c + steps * dc - goal_c) * TIE
            if key <= current_key:
                if stack_size == stack.size:
                    stack = np.concatenate((stack, np.empty(stack.size, dtype=np.int32)))
                stack[stack_size] = nxt
                stack_size += 1
                continue
            if size == capacity:
                capacity *= 2
                keys = np.concatenate((keys, np.empty(capacity - size)))
                nodes = np.concatenate((nodes, np.empty(capacity - size, dtype=np.int32)))
            _push(keys, nodes, size, key, nxt)
            size += 1
    return -1.0, expanded


@njit(cache=True, nogil=True)
def uniform_costs(cost: npt.NDArray[np.float32]) -> bool:
    """Whether every free cell costs 0 (so weighted steps cost their length alone)."""
    for v in cost.ravel():  # noqa: SIM110 - a loop numba compiles and that stops early
        if math.isfinite(v) and v != 0.0:
            return False
    return True


@njit(cache=True, nogil=True)
def route_costs_to_goal(
    cost: npt.NDArray[np.float32], cells: npt.NDArray[np.int64], cost_weight: float
) -> FloatArray:
    """[cells] Cost from each of an 8-connected route's N cells to its last, as A* weighs
    steps: L * (1 + w * (c_a + c_b) / 2) for a step of length L from a to b (with w = 0
    the costs are not read)."""
    n = cells.shape[0]
    to_goal = np.zeros(n)
    total = 0.0
    for i in range(n - 2, -1, -1):
        r, c = cells[i, 0], cells[i, 1]
        r1, c1 = cells[i + 1, 0], cells[i + 1, 1]
        length = SQRT2 if r != r1 and c != c1 else 1.0
        if cost_weight != 0.0:
            mean = 0.5 * (np.float64(cost[r, c]) + np.float64(cost[r1, c1]))  # not float32
            length *= 1.0 + cost_weight * mean
        total += length
        to_goal[i] = total
    return to_goal


@njit(cache=True, nogil=True)
def trace_back(parent: Int32Array, start: int, goal: int, cols: int) -> npt.NDArray[np.int64]:
    """The (row, col) cells from ``start`` to ``goal``, every cell of every jump included."""
    count = 1
    node = goal
    while node != start:
        before = parent[node]
        count += max(abs(node // cols - before // cols), abs(node % cols - before % cols))
        node = before
    cells = np.empty((count, 2), dtype=np.int64)
    node = goal
    i = count - 1
    cells[i, 0] = node // cols
    cells[i, 1] = node % cols
    while node != start:
        before = parent[node]
        r = node // cols
        c = node % cols
        dr = np.sign(before // cols - r)
        dc = np.sign(before % cols - c)
        while r != before // cols or c != before % cols:
            r += dr
            c += dc
            i -= 1
            cells[i, 0] = r
            cells[i, 1] = c
        node = before
    return cells


@njit(cache=True, nogil=True, inline="always")
def _seen(
    new: npt.NDArray[np.float32], old: npt.NDArray[np.float32], compare: bool, r: int, c: int
) -> float:
    """A cell's cost in ``new``; with ``compare``, inf if it differs in ``old``."""
    v = new[r, c]
    return v if not compare or v == old[r, c] else math.inf


@njit(cache=True, nogil=True)
def _segment_worst(
    new: npt.NDArray[np.float32],
    old: npt.NDArray[np.float32],
    compare: bool,
    r0: int,
    c0: int,
    r1: int,
    c1: int,
) -> float:
    """Highest ``_seen`` cost on the straight segment between two cell centres; inf as soon as
    one is blocked (or changed).

    Walks every cell the segment passes through (Amanatides and Woo's traversal); where it
    passes exactly through a cell corner, both cells beside the corner count too.
    """
    dr = r1 - r0
    dc = c1 - c0
    step_r = 1 if dr > 0 else -1
    step_c = 1 if dc > 0 else -1
    # Parameter t in [0, 1] along the segment; from a cell centre the first border is half a
    # cell away.
    t_dr = 1.0 / abs(dr) if dr != 0 else math.inf
    t_dc = 1.0 / abs(dc) if dc != 0 else math.inf
    next_r = 0.5 * t_dr
    next_c = 0.5 * t_dc
    r = r0
    c = c0
    worst = float(_seen(new, old, compare, r, c))
    while r != r1 or c != c1:
        if abs(next_r - next_c) < 1e-12:
            # Through a corner: the two side cells touch the segment too.
            worst = max(
                worst,
                _seen(new, old, compare, r + step_r, c),
                _seen(new, old, compare, r, c + step_c),
            )
            r += step_r
            c += step_c
            next_r += t_dr
            next_c += t_dc
        elif next_r < next_c:
            r += step_r
            next_r += t_dr
        else:
            c += step_c
            next_c += t_dc
        worst = max(worst, _seen(new, old, compare, r, c))
        if not math.isfinite(worst):
            return math.inf
    return worst


@njit(cache=True, nogil=True)
def segment_max_cost(cost: npt.NDArray[np.float32], r0: int, c0: int, r1: int, c1: int) -> float:
    """Highest cell cost on the straight segment between two cell centres (inf if blocked),
    the cells walked as ``_segment_worst`` walks them."""
    return _segment_worst(cost, cost, False, r0, c0, r1, c1)


@njit(cache=True, nogil=True)
def segment_changed(
    new: npt.NDArray[np.float32],
    old: npt.NDArray[np.float32],
    r0: int,
    c0: int,
    r1: int,
    c1: int,
) -> bool:
    """True if a cell the straight segment between two cell centres passes through (the cells
    ``segment_max_cost`` walks) differs between ``old`` and ``new``, or is blocked in ``new``."""
    return not math.isfinite(_segment_worst(new, old, True, r0, c0, r1, c1))


@njit(cache=True, nogil=True)
def path_changed(
    new: npt.NDArray[np.float32], old: npt.NDArray[np.float32], cells: npt.NDArray[np.int64]
) -> bool:
    """``segment_changed`` along a polyline of N x 2 (row, column) cells."""
    for i in range(cells.shape[0] - 1):
        if segment_changed(new, old, cells[i, 0], cells[i, 1], cells[i + 1, 0], cells[i + 1, 1]):
            return True
    return cells.shape[0] == 1 and not math.isfinite(
        _seen(new, old, True, cells[0, 0], cells[0, 1])
    )


@njit(cache=True, nogil=True)
def shortcut(
    cost: npt.NDArray[np.float32], cells: npt.NDArray[np.int64], slack: float, reach: int
) -> npt.NDArray[np.int64]:
    """Indices of the cells kept when the path is straightened by line of sight.

    From each kept cell the path jumps to the farthest later cell (at most ``reach`` ahead)
    whose straight segment is free and never costlier than the path it replaces plus
    ``slack``, so smoothing never takes the route closer to walls than A* did.
    """
    n = cells.shape[0]
    keep = np.empty(n, dtype=np.int64)
    count = 0
    i = 0
    while i < n - 1:
        keep[count] = i
        count += 1
        best = i + 1
        path_worst = max(cost[cells[i, 0], cells[i, 1]], cost[cells[i + 1, 0], cells[i + 1, 1]])
        for j in range(i + 2, min(n, i + reach + 1)):
            path_worst = max(path_worst, cost[cells[j, 0], cells[j, 1]])
            line = segment_max_cost(cost, cells[i, 0], cells[i, 1], cells[j, 0], cells[j, 1])
            if not math.isfinite(line):
                break  # out of sight: farther cells are very rarely visible again
            if line <= path_worst + slack:
                best = j
        i = best
    keep[count] = n - 1
    count += 1
    return keep[:count]
