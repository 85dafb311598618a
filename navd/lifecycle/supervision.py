"""Supervision bookkeeping: handler failures and slow handlers, per module.

A module that fails ``max_failures`` times within ``window_s`` is faulted: the bus then
makes the robot safe. The fault clears by itself once a whole window passes without a
failure, so a transient glitch does not park the robot forever, while a module that keeps
failing keeps it parked.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

__all__ = ["ModuleRecord", "Supervisor"]


@dataclass
class ModuleRecord:
    """Counters of one module. Times are [s] on the daemon clock."""

    failures: int = 0
    slow_handlers: int = 0
    recent_failures: deque[float] = field(default_factory=deque)
    faulted_since: float | None = None
    last_error: str = ""


class Supervisor:
    """Counts failures per module and decides when a module is faulted.

    Args:
        max_failures: failures within ``window_s`` that fault a module.
        window_s: [s] length of the counting window.
    """

    def __init__(self, max_failures: int, window_s: float) -> None:
        self.max_failures = max_failures
        self.window_s = window_s
        self._records: dict[str, ModuleRecord] = {}

    def record(self, module: str) -> ModuleRecord:
        """The counters of ``module`` (created empty on first use)."""
        return self._records.setdefault(module, ModuleRecord())

    def record_failure(self, module: str, now_s: float, error: str) -> bool:
        """Count a failure at ``now_s`` [s]; True if this failure newly faults the module."""
        rec = self.record(module)
        rec.failures += 1
        rec.last_error = error
        rec.recent_failures.append(now_s)
        self._expire(rec, now_s)
        if rec.faulted_since is None and len(rec.recent_failures) >= self.max_failures:
            rec.faulted_since = now_s
            return True
        return False

    def record_slow(self, module: str) -> None:
        """Count a handler that overran its budget."""
        self.record(module).slow_handlers += 1

    def clear_recovered(self, now_s: float) -> list[str]:
        """Clear faults with no failure in the last window; returns the modules cleared."""
        cleared = []
        for name, rec in self._records.items():
            self._expire(rec, now_s)
            if rec.faulted_since is not None and not rec.recent_failures:
                rec.faulted_since = None
                cleared.append(name)
        return cleared

    def faulted(self) -> dict[str, ModuleRecord]:
        """The modules currently faulted, by name."""
        return {n: r for n, r in self._records.items() if r.faulted_since is not None}

    def _expire(self, rec: ModuleRecord, now_s: float) -> None:
        while rec.recent_failures and rec.recent_failures[0] <= now_s - self.window_s:
            rec.recent_failures.popleft()
