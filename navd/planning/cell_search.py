"""The cell route between two cells of a costmap: which search runs, and its working memory.

A uniform grid (every step costs its length) is searched by jump point search, a grid with
cell costs by the bucket search (``_bucket_kernels``), both from the robot toward the goal.

"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.planning._astar_kernels import (
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
from navd.planning.costmap import Costmap

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
        expanded: cells the search expanded: jump points, or cells taken out of buckets (not
            those a pass along floor went over).
    """

    cells: CellArray
    cost_cells: float
    expanded: int


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


class CellSearch:
    """Routes between cells, one search at a time, its working memory kept between them."""

    def __init__(self) -> None:
        self._memory = SearchMemory(0)
        self.last_expanded = 0  # cells the last search expanded, whether it found a route

    def route(
        self, costmap: Costmap, start_cell: int, goal_cell: int, cost_weight: float
    ) -> CellRoute | None:
        """The cheapest route from flat cell ``start_cell`` to ``goal_cell`` (both free), or
        None if there is none (``last_expanded`` says how far the search looked)."""
        cols = costmap.frame.cols
        if cost_weight == 0.0 or uniform_costs(costmap.cost):
            memory = self._reserve(costmap.frame.rows * cols)
            rows_free, cols_free = pack_free_cells(costmap.blocked)
            g_cells, self.last_expanded = jump_point_search(
                cols, start_cell, goal_cell, *memory.jumps(), rows_free, cols_free
            )
            if g_cells < 0.0:
                return None
            cells = trace_back(memory.links, start_cell, goal_cell, cols)
            return CellRoute(cells, g_cells, self.last_expanded)
        ceiling = COST_CEILING
        while True:
            memory = self._reserve(costmap.frame.rows * cols)
            g_cells, self.last_expanded = bucket_astar(
                np.ascontiguousarray(costmap.cost, dtype=np.float32),
                start_cell,
                goal_cell,
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
        if g_cells < 0.0:
            return None
        cells = trace_steps(memory.mark, start_cell, goal_cell, cols)
        return CellRoute(cells, float(g_cells), self.last_expanded)

    def _reserve(self, cells: int) -> SearchMemory:
        """Working arrays for ``cells`` cells, with a fresh generation number."""
        if cells > self._memory.cells or self._memory.generation >= MAX_GENERATION:
            self._memory = SearchMemory(max(cells, self._memory.cells))
        self._memory.generation += 1
        return self._memory
