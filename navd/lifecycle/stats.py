"""Percentiles, the one definition navd's figures use, and a fixed window of recent samples.

A percentile is linearly interpolated between ranks (numpy's default method): the q-th
percentile of n sorted values v is v[r] + (v[r + 1] - v[r]) * (k - r) with k = q / 100 *
(n - 1) and r = floor(k).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import numpy.typing as npt

__all__ = ["RollingWindow", "percentile", "percentiles"]


def percentiles(values: Iterable[float], qs: Sequence[float]) -> tuple[float, ...]:
    """Several percentiles (each 0..100) of ``values`` with one sort; NaN when empty."""
    ordered = np.sort(np.fromiter(values, dtype=np.float64))
    return _ranked(ordered, qs)


def percentile(values: Iterable[float], q: float) -> float:
    """The q-th percentile (0..100) of ``values``; NaN when empty."""
    return percentiles(values, (q,))[0]


def _ranked(ordered: npt.NDArray[np.float64], qs: Sequence[float]) -> tuple[float, ...]:
    n = ordered.size
    if n == 0:
        return tuple(float("nan") for _ in qs)
    out = []
    for q in qs:
        rank = q / 100.0 * (n - 1)
        low = int(rank)
        high = min(low + 1, n - 1)
        out.append(float(ordered[low] + (ordered[high] - ordered[low]) * (rank - low)))
    return tuple(out)


class RollingWindow:
    """The last ``capacity`` samples of one quantity, in a ring buffer.

    Args:
        capacity: how many samples are kept (memory is fixed).
    """

    def __init__(self, capacity: int) -> None:
        if capacity <= 0:
            raise ValueError(f"capacity must be > 0, got {capacity}")
        self._values = np.zeros(capacity, dtype=np.float64)
        self._count = 0

    def add(self, value: float) -> None:
        self._values[self._count % self._values.size] = value
        self._count += 1

    def __len__(self) -> int:
        return min(self._count, self._values.size)

    @property
    def total(self) -> int:
        """How many samples were ever added."""
        return self._count

    def percentile(self, q: float) -> float:
        """The q-th percentile (0..100) of the kept samples; 0.0 when empty."""
        return self.percentiles((q,))[0]

    def percentiles(self, qs: tuple[float, ...]) -> tuple[float, ...]:
        """Several percentiles (0..100) of the kept samples with one sort; zeros when empty."""
        n = len(self)
        if n == 0:
            return tuple(0.0 for _ in qs)
        return _ranked(np.sort(self._values[:n]), qs)

    def max(self) -> float:
        """The largest kept sample; 0.0 when empty."""
        n = len(self)
        return float(self._values[:n].max()) if n else 0.0
