"""Event queue and state queue (seed §3.10): late measurements correct the past.

Every event and every state carries its measurement time. Events are kept in time order
with the filter state after each one. An event stamped before the newest state rewinds to
the last state before it, is applied there, and every later event is re-applied in time
order. An event stamped in the future (clock skew) waits until its time comes. An event
older than the horizon (or than the oldest state kept) is dropped and counted. Memory is
bounded by the horizon and by ``max_events``.
"""

from __future__ import annotations

import bisect
import heapq
import itertools
import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
import numpy.typing as npt

from navd.config import EstimationConfig
from navd.estimation.motion_model import STATE_SIZE, TH
from navd.estimation.ukf import MAX_YAW_STD_RAD, Measurement, PoseUkf, StepOutcome

__all__ = ["Event", "EventHistory", "HistorySettings", "Insert", "Snapshot"]

FloatArray = npt.NDArray[np.float64]

# An event this close to "now" or earlier is applied at once, not deferred.
FUTURE_TOLERANCE_S = 1e-3
# Smallest and largest variance [unit²] a reset leaves on any state element: repeated
# resets must not compound into an overflow.
RESET_VARIANCE_FLOOR = 1e-6
RESET_VARIANCE_CEILING = 1e4


@dataclass(frozen=True, slots=True)
class Event:
    """A measurement to apply at its time.

    Attributes:
        stamp: [s] measurement time.
        source: sensor kind, for counters ("lidar", "gps", "compass", "wheel").
        measurement: rows, values and noise.
        gate_chi2: Mahalanobis gate for the measurement's own rows.
    """

    stamp: float
    source: str
    measurement: Measurement
    gate_chi2: float


@dataclass(frozen=True, slots=True)
class Snapshot:
    """The filter state at a time: mean ``x`` and covariance ``p`` (read-only arrays)."""

    stamp: float
    x: FloatArray
    p: FloatArray

    @staticmethod
    def of(stamp: float, x: FloatArray, p: FloatArray) -> Snapshot:
        x = np.array(x, dtype=np.float64)
        p = np.array(p, dtype=np.float64)
        x.flags.writeable = False
        p.flags.writeable = False
        return Snapshot(stamp, x, p)


class Insert(Enum):
    """What happened to an inserted event."""

    APPLIED = "applied"  # newest event: applied on top
    REPLAYED = "replayed"  # late: the past was rewound and re-applied
    DEFERRED = "deferred"  # stamped in the future: waits for its time
    TOO_OLD = "too_old"  # older than the horizon: dropped


@dataclass
class Counters:
    """Running counts, by event source where it matters."""

    applied: int = 0
    replayed: int = 0
    reapplied: int = 0
    deferred: int = 0
    too_old: int = 0
    overflow: int = 0
    resets: int = 0
    rejected: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class HistorySettings:
    """How far back the history reaches.

    Attributes:
        horizon_s: [s] how far back late events are accepted.
        max_events: most events kept (and most deferred).
        reset_inflation: covariance scale when the filter is reset after a numerical failure.
    """

    horizon_s: float
    max_events: int
    reset_inflation: float

    @classmethod
    def of(cls, est: EstimationConfig) -> HistorySettings:
        """The settings of an estimation section."""
        return cls(est.history_horizon_s, est.max_events, est.reset_inflation)


class EventHistory:
    """The filter driven by time-ordered events, able to rewind.

    Args:
        ukf: the filter to drive (its state is owned by the history from now on; ``ukf``
            may be replaced by one with other settings at any time).
        settings: horizon, event bound and reset inflation; ``settings`` may be replaced
            whole at any time (events kept beyond a shorter horizon go at the next insert).
    """

    def __init__(self, ukf: PoseUkf, settings: HistorySettings) -> None:
        self.ukf = ukf
        self.settings = settings
        self.counters = Counters()
        self.last_rejected_mahalanobis_sq = math.nan
        self._base: Snapshot | None = None
        self._events: list[Event] = []
        self._stamps: list[float] = []
        self._after: list[Snapshot] = []
        self._future: list[tuple[float, int, Event]] = []
        self._order = itertools.count()

    @property
    def initialized(self) -> bool:
        """True once a state has been set."""
        return self._base is not None

    @property
    def latest(self) -> Snapshot:
        """The newest state.

        Raises:
            RuntimeError: before ``initialize``.
        """
        if self._after:
            return self._after[-1]
        if self._base is None:
            raise RuntimeError("EventHistory.latest before initialize()")
        return self._base

    def at_or_before(self, stamp: float) -> Snapshot:
        """The state after the last event at or before ``stamp`` [s] (the start when none).

        Raises:
            RuntimeError: before ``initialize``.
        """
        k = bisect.bisect_right(self._stamps, stamp)
        if k > 0:
            return self._after[k - 1]
        if self._base is None:
            raise RuntimeError("EventHistory.at_or_before before initialize()")
        return self._base

    @property
    def event_count(self) -> int:
        """Events kept for rewinding, plus those waiting for their time."""
        return len(self._events) + len(self._future)

    def initialize(self, stamp: float, x: FloatArray, p: FloatArray) -> None:
        """Start (or restart) from a state at ``stamp`` [s]; forgets all events."""
        if x.shape != (STATE_SIZE,) or p.shape != (STATE_SIZE, STATE_SIZE):
            raise ValueError(f"state must be ({STATE_SIZE},) and ({STATE_SIZE}, {STATE_SIZE})")
        self._base = Snapshot.of(stamp, x, p)
        self._events.clear()
        self._stamps.clear()
        self._after.clear()
        self._future.clear()

    def insert(self, event: Event, now: float) -> Insert:
        """Apply ``event`` at its time, rewinding if it is late.

        Args:
            event: the measurement.
            now: [s] the current time (what "late" and "future" are measured against).
        """
        if self._base is None:
            raise RuntimeError("EventHistory.insert before initialize()")
        if event.stamp > now + FUTURE_TOLERANCE_S:
            self._defer(event)
            return Insert.DEFERRED
        if event.stamp < now - self.settings.horizon_s or event.stamp < self._base.stamp:
            self.counters.too_old += 1
            return Insert.TOO_OLD
        index = bisect.bisect_right(self._stamps, event.stamp)
        self._events.insert(index, event)
        self._stamps.insert(index, event.stamp)
        del self._after[index:]
        late = index < len(self._events) - 1
        for i in range(index, len(self._events)):
            self._after.append(self._apply(self._events[i], self.latest, first=i == index))
        if late:
            self.counters.replayed += 1
            self.counters.reapplied += len(self._events) - index - 1
        else:
            self.counters.applied += 1
        self._prune(now)
        return Insert.REPLAYED if late else Insert.APPLIED

    def advance(self, now: float) -> int:
        """Apply deferred events whose time has come; returns how many."""
        due = 0
        while self._future and self._future[0][0] <= now + FUTURE_TOLERANCE_S:
            _, _, event = heapq.heappop(self._future)
            self.insert(event, now)
            due += 1
        return due

    def _defer(self, event: Event) -> None:
        self.counters.deferred += 1
        heapq.heappush(self._future, (event.stamp, next(self._order), event))
        if len(self._future) > self.settings.max_events:
            # Keep the soonest; the farthest-future event is the least believable.
            self._future.remove(max(self._future))
            heapq.heapify(self._future)
            self.counters.overflow += 1

    def _apply(self, event: Event, before: Snapshot, *, first: bool) -> Snapshot:
        """The state after ``event``, starting from ``before`` (reset if the math fails).

        Rejections and resets are counted on an event's ``first`` application only, not
        again when a late event makes it re-applied.
        """
        self.ukf.set_state(before.x, before.p)
        dt = max(event.stamp - before.stamp, 0.0)
        outcome = self.ukf.step(dt, event.measurement, event.gate_chi2)
        if outcome is StepOutcome.DIVERGED:
            self.counters.resets += first
            # Keep the last good mean; a diagonal, inflated covariance is certainly valid.
            variances = np.clip(
                np.diag(before.p) * self.settings.reset_inflation,
                RESET_VARIANCE_FLOOR,
                RESET_VARIANCE_CEILING,
            )
            variances[TH] = min(variances[TH], MAX_YAW_STD_RAD**2)
            return Snapshot.of(event.stamp, before.x, np.diag(variances))
        if outcome is StepOutcome.REJECTED and first:
            rejected = self.counters.rejected
            rejected[event.source] = rejected.get(event.source, 0) + 1
            self.last_rejected_mahalanobis_sq = self.ukf.last_mahalanobis_sq
        return Snapshot.of(event.stamp, self.ukf.x, self.ukf.p)

    def _prune(self, now: float) -> None:
        """Forget events older than the horizon, and the oldest beyond ``max_events``."""
        cutoff = bisect.bisect_left(self._stamps, now - self.settings.horizon_s)
        excess = len(self._events) - self.settings.max_events
        if excess > cutoff:
            self.counters.overflow += excess - cutoff
            cutoff = excess
        if cutoff > 0:
            self._base = self._after[cutoff - 1]
            del self._events[:cutoff]
            del self._stamps[:cutoff]
            del self._after[:cutoff]
