"""The robustness suite: a log replayed as it is, then made worse in each way ``perturb``
knows and in the combinations that stand for the held-out logs' conditions, every replay
with the same settings; each scored on the log's relations against the unperturbed run.

The figure of record is the worst ratio of a perturbed run's mean translational relation
error to the unperturbed one's (docs/slam.md, "Perturbed logs").
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from navd.geometry import LidarMount
from navd.offline.logfiles import LogScan
from navd.offline.perturb import COMBINATIONS, PERTURBATIONS, perturb
from navd.offline.relations import Relation, RelationErrors, evaluate
from navd.offline.replay import replay
from navd.slam import MapperSettings

__all__ = ["SUITE", "SuiteRow", "run_suite", "suite_table", "worst_row"]

SUITE = (*PERTURBATIONS, *COMBINATIONS)  # what the suite runs unless told otherwise
UNPERTURBED = "none"  # the name of the log as it is, in the suite's rows
COUNTS = ("weak_matches", "doubtful", "lost", "odometry_spikes", "implausible_steps")


@dataclass(frozen=True, slots=True)
class SuiteRow:
    """One replay of the suite: its ``kind`` (UNPERTURBED for the log as it is), its relation
    errors, their translational mean over the unperturbed run's (``ratio``), and tracking's
    counts and the replay's wall time from its summary."""

    kind: str
    errors: RelationErrors
    ratio: float
    counts: dict[str, int]
    wall_s: float

    def as_dict(self) -> dict[str, object]:
        return {
            "kind": self.kind,
            **self.errors.as_dict(),
            "ratio": round(self.ratio, 3),
            **self.counts,
            "wall_seconds": round(self.wall_s, 1),
        }


def run_suite(
    scans: Callable[[], Iterable[LogScan]],
    relations: Sequence[Relation],
    settings: MapperSettings,
    mount: LidarMount,
    out_dir: Path,
    *,
    kinds: Sequence[str] = SUITE,
    seed: int = 0,
    progress: Callable[[SuiteRow], None] | None = None,
) -> list[SuiteRow]:
    """Replay ``scans()`` (a fresh pass each call) as it is and with each of ``kinds``,
    results in ``out_dir/<kind>``; the rows, the unperturbed first.

    Raises:
        ValueError: an unknown kind, before any replay.
        LogFormatError: a scan the log cannot give.
    """
    for kind in kinds:
        next(perturb((), kind), None)  # refuses an unknown kind at once
    rows: list[SuiteRow] = []
    base = math.nan
    for kind in (UNPERTURBED, *kinds):
        source = scans() if kind == UNPERTURBED else perturb(scans(), kind, seed)
        result = replay(source, out_dir / kind, settings, mount=mount)
        errors = evaluate(result.stamps, result.poses, list(relations))
        if kind == UNPERTURBED:
            base = errors.translation_mean_m
        summary = result.summary
        row = SuiteRow(
            kind,
            errors,
            errors.translation_mean_m / base if base > 0 else math.nan,
            {name: int(_number(summary.get(name))) for name in COUNTS},
            _number(summary.get("wall_seconds")),
        )
        rows.append(row)
        if progress is not None:
            progress(row)
    return rows


def worst_row(rows: Sequence[SuiteRow]) -> SuiteRow:
    """The perturbed run furthest from the unperturbed one (the figure of record); a run
    that gave no relation errors at all counts as the worst."""
    perturbed = [r for r in rows if r.kind != UNPERTURBED] or list(rows)
    return max(perturbed, key=lambda r: math.inf if math.isnan(r.ratio) else r.ratio)


def suite_table(rows: Sequence[SuiteRow]) -> str:
    """The rows as a Markdown table (docs/slam.md's form)."""
    head = "| perturbation | mean error [m] | ratio | " + " | ".join(COUNTS) + " | wall [s] |"
    lines = [head, "|" + " --- |" * (5 + len(COUNTS) - 1)]
    for r in rows:
        counts = " | ".join(str(r.counts[name]) for name in COUNTS)
        lines.append(
            f"| {r.kind} | {r.errors.translation_mean_m:.4f} | {r.ratio:.2f} | {counts} "
            f"| {r.wall_s:.0f} |"
        )
    return "\n".join(lines)


def _number(value: object) -> float:
    """A summary's figure (0 for one it lacks)."""
    return float(value) if isinstance(value, int | float) else 0.0
