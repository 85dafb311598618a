"""Timing calls for the benchmarks: medians in milliseconds, alone or in turn with a peer."""

from __future__ import annotations

import time
from collections.abc import Callable

from navd.lifecycle import percentile

__all__ = ["median_ms", "paired_ms"]


def median_ms(call: Callable[[], object], repeats: int) -> float:
    """[ms] median of ``repeats`` calls after one untimed call (compiles, sizes buffers)."""
    call()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return 1e3 * percentile(times, 50)


def paired_ms(
    ours: Callable[[], object], peer: Callable[[], object], repeats: int
) -> tuple[float, float]:
    """[ms] medians of ``ours`` and of ``peer``, run in turn ``repeats`` times each after one
    untimed call of each: drifts of a noisy machine hit both alike."""
    ours()
    peer()
    times: tuple[list[float], list[float]] = ([], [])
    for _ in range(repeats):
        for call, into in ((ours, times[0]), (peer, times[1])):
            start = time.perf_counter()
            call()
            into.append(time.perf_counter() - start)
    return 1e3 * percentile(times[0], 50), 1e3 * percentile(times[1], 50)
