"""The worker jobs of a recorded run, for a replay to follow (``WorkerPool.follow``).

On real time a job runs in a thread and its result comes some milliseconds later, or the
job is dropped because a newer one of its slot replaced it while it waited; a replay on
simulated time would otherwise run every job at once, as an infinitely fast computer, and
drift from what was recorded (a scan matched later, a plan a step behind). So a replayed job
is matched to the recorded job of its slot submitted at the same moment (within
``MATCH_S``, in order), and runs as that one did: dropped, or begun and published after the
same delays. A module's set-up (a filter built beside the loop at start) takes effect when
the recorded one did.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Iterable
from dataclasses import dataclass

from navd.lifecycle.messages import SetUpDone, WorkerJob

__all__ = ["MATCH_S", "RecordedJob", "WorkScript"]

# [s] a recorded job and a replayed one of the same slot are the same job when submitted
# this close (the real loop hands a job over a little after its input's arrival)
MATCH_S = 0.04


@dataclass(frozen=True, slots=True)
class RecordedJob:
    """How a recorded job went, from its submission.

    Attributes:
        submitted_s: [s] when, on the recorded run's clock.
        start_after_s, finish_after_s: [s] after its submission, when it began and when its
            result was published.
        dropped: a newer job of its slot replaced it before it ran.
    """

    submitted_s: float
    start_after_s: float
    finish_after_s: float
    dropped: bool


class WorkScript:
    """Recorded jobs by slot, handed out as a replay submits their counterparts.

    Args:
        jobs: the recorded run's ``WorkerJob`` messages, in any order.
        set_ups: the recorded run's ``SetUpDone`` messages.

    Attributes:
        shift_s: [s] replay time minus recorded time (``known`` once the replay set it).
        followed: replayed jobs matched to a recorded one.
        unmatched: replayed jobs with no recorded counterpart (run at once).
        missed: recorded jobs the replay never submitted.
    """

    def __init__(self, jobs: Iterable[WorkerJob], set_ups: Iterable[SetUpDone] = ()) -> None:
        self._set_ups = {done.name: done.stamp for done in set_ups}
        self.known = asyncio.Event()
        self._shift_s = 0.0
        slots: dict[str, list[RecordedJob]] = {}
        for job in jobs:
            dropped = job.outcome == "dropped" or not math.isfinite(job.finished_s)
            begun = 0.0 if dropped else max(0.0, job.started_s - job.submitted_s)
            done = 0.0 if dropped else max(begun, job.finished_s - job.submitted_s)
            slots.setdefault(job.slot, []).append(
                RecordedJob(job.submitted_s, begun, done, dropped)
            )
        for recorded in slots.values():
            recorded.sort(key=lambda r: r.submitted_s)
        self._slots = slots
        self._next = dict.fromkeys(slots, 0)
        self.followed = self.unmatched = self.missed = 0

    @property
    def shift_s(self) -> float:
        return self._shift_s

    @shift_s.setter
    def shift_s(self, value: float) -> None:
        self._shift_s = value
        self.known.set()

    def set_up_at(self, name: str) -> float | None:
        """[s] when the set-up ``name`` took effect on the recorded run's clock, or None."""
        return self._set_ups.get(name)

    def __len__(self) -> int:
        return sum(len(jobs) for jobs in self._slots.values())

    def take(self, slot: str, now_s: float) -> RecordedJob | None:
        """The recorded job that a job of ``slot`` submitted at ``now_s`` (replay time)
        stands for, or None when none was submitted then."""
        jobs = self._slots.get(slot)
        if not jobs:
            self.unmatched += 1
            return None
        t = now_s - self.shift_s
        i = self._next[slot]
        while i < len(jobs) and jobs[i].submitted_s < t - MATCH_S:
            i += 1  # the replay never submitted it
            self.missed += 1
        if i < len(jobs) and jobs[i].submitted_s <= t + MATCH_S:
            self._next[slot] = i + 1
            self.followed += 1
            return jobs[i]
        self._next[slot] = i
        self.unmatched += 1
        return None
