"""The cell route between two cells of a costmap: which search runs, its working memory, and
the reuse of the last search when the robot replans toward the same goal.

A uniform grid (every step costs its length) is searched forward by jump point search. A grid
with cell costs is searched by the bucket search *from the goal* toward the robot: every cell
it closes then knows its cost to the goal and the step toward it. When the robot asks again
for the same goal (the replan timer, a detour, a new obstacle), the route from where it
stands now is read off that tree, without a search, if nothing makes it wrong:

- the grid and the goal cell are the same, with the same cost weight;
- the robot's cell was closed by the last search (its cost to the goal is final);
- no cell got cheaper (a cell that did could open a better route), and no cell on the route
  read off, nor beside one of its diagonal steps (which need both side cells free), got
  costlier.

When costs only rose, and not on the route, the route keeps its cost and no other route got
cheaper, so it is as good as a new search would find (within the same bound). Anything else
searches afresh. A costmap is never changed in place (each is built anew), so the last one's
cost array is kept by reference to compare with (4 bytes a cell held until the next search;
the comparison costs about a millisecond on a 2000 x 2000 grid, a search tens).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.planning._astar_kernels import (
    CLOSED,
    MAX_GENERATION,
    jump_point_search,
    trace_back,
    uniform_costs,
)
from navd.planning._bitgrid_kernels import pack_free_cells
from navd.planning._bucket_kernels import (
    BUCKETS_PER_CELL,
    CEILING_TOO_LOW,
    COST_CEILING,
    bucket_astar,
    trace_steps,
)
from navd.planning.costmap import Costmap, GridFrame

__all__ = ["CellRoute", "CellSearch", "SearchMemory"]

FloatArray = npt.NDArray[np.float64]
Int32Array = npt.NDArray[np.int32]
CellArray = npt.NDArray[np.int64]


@dataclass(frozen=True, slots=True)
class CellRoute:
    """A route found between two cells.

    Attributes:
        cells: N x 2 (row, col) cells from the start to the goal.
        cost_cells: the route's cost in cells of length (weighted by the cells' costs).
        expanded: cells the search expanded (0 when the route was read off the last search).
        reused: read off the last search's tree.
    """

    cells: CellArray
    cost_cells: float
    expanded: int
    reused: bool


class SearchMemory:
    """One planner's working arrays, kept between searches (generation-stamped, so never
    cleared) and made only for the kind of search that needs them: 8 bytes a cell for the
    marks and links, 12 more for the bucket search (costs, back links) or 8 for jump point
    search (costs)."""

    def __init__(self, cells: int) -> None:
        self.cells = cells
        self.generation = 0
        self.mark = np.zeros(cells, dtype=np.int32)
        self.links = np.empty(cells, dtype=np.int32)  # jump parents, or next in a bucket
        self.g: FloatArray | None = None
        self._prev: Int32Array | None = None

    def jumps(self) -> tuple[FloatArray, Int32Array, Int32Array, int]:
        """(g, mark, parent, generation) for ``jump_point_search``."""
        if self.g is None:
            self.g = np.empty(self.cells)
        return self.g, self.mark, self.links, self.generation

    def buckets(self) -> tuple[FloatArray, Int32Array, Int32Array, Int32Array, int]:
        """(g, mark, next_open, prev_open, generation) for ``bucket_astar``."""
        if self.g is None:
            self.g = np.empty(self.cells)
        if self._prev is None:
            self._prev = np.empty(self.cells, dtype=np.int32)
        return self.g, self.mark, self.links, self._prev, self.generation


@dataclass(frozen=True, slots=True)
class _Tree:
    """What the last bucket search was run on (its results are in the memory, stamped with
    ``generation``)."""

    frame: GridFrame
    cost: npt.NDArray[np.float32]
    goal_cell: int
    cost_weight: float
    generation: int


class CellSearch:
    """Routes between cells, one search at a time, reusing the last where it can."""

    def __init__(self) -> None:
        self._memory = SearchMemory(0)
        self._tree: _Tree | None = None
        self.last_expanded = 0  # cells the last search expanded, whether it found a route

    def forget(self) -> None:
        """Search afresh next time (the benchmarks time searches, not reuse)."""
        self._tree = None

    def route(
        self, costmap: Costmap, start_cell: int, goal_cell: int, cost_weight: float
    ) -> CellRoute | None:
        """The cheapest route from flat cell ``start_cell`` to ``goal_cell`` (both free), or
        None if there is none (``last_expanded`` says how far the search looked)."""
        cols = costmap.frame.cols
        if cost_weight == 0.0 or uniform_costs(costmap.cost):
            self._tree = None
            memory = self._reserve(costmap.frame.rows * cols)
            rows_free, cols_free = pack_free_cells(costmap.cost)
            g_cells, self.last_expanded = jump_point_search(
                cols, start_cell, goal_cell, *memory.jumps(), rows_free, cols_free
            )
            if g_cells < 0.0:
                return None
            cells = trace_back(memory.links, start_cell, goal_cell, cols)
            return CellRoute(cells, g_cells, self.last_expanded, reused=False)
        reused = self._reuse(costmap, start_cell, goal_cell, cost_weight)
        if reused is not None:
            self.last_expanded = 0
            return reused
        g_cells = self._search_from_goal(costmap, start_cell, goal_cell, cost_weight)
        if g_cells < 0.0:
            return None
        cells = trace_steps(self._memory.mark, goal_cell, start_cell, cols)[::-1]
        return CellRoute(np.ascontiguousarray(cells), g_cells, self.last_expanded, reused=False)

    def _search_from_goal(
        self, costmap: Costmap, start_cell: int, goal_cell: int, cost_weight: float
    ) -> float:
        """The bucket search rooted at the goal; the tree is kept for the next request."""
        self._tree = None
        ceiling = COST_CEILING
        while True:
            memory = self._reserve(costmap.frame.rows * costmap.frame.cols)
            g_cells, self.last_expanded = bucket_astar(
                costmap.cost,
                goal_cell,
                start_cell,
                cost_weight,
                *memory.buckets(),
                float(BUCKETS_PER_CELL),
                ceiling,
            )
            if g_cells != CEILING_TOO_LOW:
                break
            # Costs beyond the costmap's scale: a ring of buckets wide enough for them.
            cost = costmap.cost
            ceiling = float(np.max(cost, where=np.isfinite(cost), initial=0.0))
        self._tree = _Tree(
            costmap.frame, costmap.cost, goal_cell, cost_weight, self._memory.generation
        )
        return float(g_cells)

    def _reuse(
        self, costmap: Costmap, start_cell: int, goal_cell: int, cost_weight: float
    ) -> CellRoute | None:
        """The route read off the last search, if nothing makes it wrong (module docstring)."""
        tree, memory = self._tree, self._memory
        if (
            tree is None
            or memory.g is None
            or tree.generation != memory.generation
            or tree.goal_cell != goal_cell
            or tree.cost_weight != cost_weight
            or tree.frame != costmap.frame
        ):
            return None
        mark = int(memory.mark[start_cell])
        if mark >> 4 != tree.generation or not mark & CLOSED:
            return None
        cells = trace_steps(memory.mark, goal_cell, start_cell, costmap.frame.cols)[::-1]
        if costmap.cost is not tree.cost:
            new, old = costmap.cost, tree.cost
            changed = new != old
            if changed.any():
                if np.any(new[changed] < old[changed]):
                    return None  # something got cheaper: a better route may exist
                if changed[cells[:, 0], cells[:, 1]].any():
                    return None  # the route itself got costlier
                # A diagonal step is allowed only while both cells beside it are free.
                steps = np.diff(cells, axis=0)
                diagonal = np.flatnonzero(np.all(steps != 0, axis=1))
                before, after = cells[diagonal], cells[diagonal + 1]
                if (
                    changed[before[:, 0], after[:, 1]].any()
                    or changed[after[:, 0], before[:, 1]].any()
                ):
                    return None  # a cell beside a diagonal step changed
        return CellRoute(np.ascontiguousarray(cells), float(memory.g[start_cell]), 0, reused=True)

    def _reserve(self, cells: int) -> SearchMemory:
        """Working arrays for ``cells`` cells, with a fresh generation number."""
        if cells > self._memory.cells or self._memory.generation >= MAX_GENERATION:
            self._memory = SearchMemory(max(cells, self._memory.cells))
        self._memory.generation += 1
        return self._memory
