"""The Kümmerle et al. (2009) relation metric of a trajectory.

For each relation (t1, t2, δ) with δ the true pose at t2 seen from the pose at t1, the
trajectory's estimate is δ̂ = x(t1)⁻¹ ⊕ x(t2) and the error e = δ⁻¹ ⊕ δ̂; reported are the
mean and standard deviation of |translation(e)| [m] and |rotation(e)| [deg] over the
relations whose two stamps the trajectory has (within ``tolerance_s``).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from navd.geometry import Pose2
from navd.offline.errors import LogFormatError

__all__ = ["Relation", "RelationErrors", "evaluate", "read_relations", "read_tum"]


@dataclass(frozen=True, slots=True)
class Relation:
    """The true relative pose between the robot at two times."""

    t1: float
    t2: float
    delta: Pose2


@dataclass(frozen=True, slots=True)
class RelationErrors:
    """Mean and standard deviation of the relation errors, and how many relations were used."""

    translation_mean_m: float
    translation_std_m: float
    rotation_mean_deg: float
    rotation_std_deg: float
    used: int
    missing: int

    def as_dict(self) -> dict[str, float | int]:
        return {
            "translation_mean_m": round(self.translation_mean_m, 4),
            "translation_std_m": round(self.translation_std_m, 4),
            "rotation_mean_deg": round(self.rotation_mean_deg, 3),
            "rotation_std_deg": round(self.rotation_std_deg, 3),
            "used": self.used,
            "missing": self.missing,
        }


def read_relations(path: Path) -> list[Relation]:
    """Relations from a ``.relations`` file: t1 t2 x y z roll pitch yaw per line.

    Raises:
        LogFormatError: a line that is not eight numbers (file and line named).
    """
    relations = []
    for number, line in enumerate(path.read_text(encoding="ascii").splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        try:
            t1, t2, x, y, _z, _roll, _pitch, yaw = (float(v) for v in line.split())
        except ValueError as err:
            raise LogFormatError(
                f"{path}:{number}: expected 't1 t2 x y z roll pitch yaw', got {line[:60]!r}"
            ) from err
        relations.append(Relation(t1, t2, Pose2(x, y, yaw)))
    return relations


def read_tum(path: Path) -> tuple[list[float], list[Pose2]]:
    """Stamps and planar poses of a TUM trajectory (stamp x y z qx qy qz qw per line).

    Raises:
        LogFormatError: a line that is not eight numbers.
    """
    stamps: list[float] = []
    poses: list[Pose2] = []
    for number, line in enumerate(path.read_text(encoding="ascii").splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        try:
            t, x, y, _z, qx, qy, qz, qw = (float(v) for v in line.split())
        except ValueError as err:
            raise LogFormatError(
                f"{path}:{number}: expected 'stamp x y z qx qy qz qw', got {line[:60]!r}"
            ) from err
        yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        stamps.append(t)
        poses.append(Pose2(x, y, yaw))
    return stamps, poses


def _pose_at(stamps: list[float], poses: list[Pose2], t: float, tolerance_s: float) -> Pose2 | None:
    i = bisect.bisect_left(stamps, t)
    best = None
    for j in (i - 1, i):
        near = 0 <= j < len(stamps) and abs(stamps[j] - t) <= tolerance_s
        if near and (best is None or abs(stamps[j] - t) < abs(stamps[best] - t)):
            best = j
    return None if best is None else poses[best]


def evaluate(
    stamps: list[float],
    poses: list[Pose2],
    relations: list[Relation],
    tolerance_s: float = 1e-3,
) -> RelationErrors:
    """The relation errors of a trajectory (stamps ascending)."""
    translation = []
    rotation = []
    missing = 0
    for rel in relations:
        a = _pose_at(stamps, poses, rel.t1, tolerance_s)
        b = _pose_at(stamps, poses, rel.t2, tolerance_s)
        if a is None or b is None:
            missing += 1
            continue
        error = rel.delta.inverse().compose(a.between(b))
        translation.append(math.hypot(error.x, error.y))
        rotation.append(abs(math.degrees(error.yaw)))
    if not translation:
        return RelationErrors(math.nan, math.nan, math.nan, math.nan, 0, missing)
    t = np.array(translation)
    r = np.array(rotation)
    return RelationErrors(
        float(t.mean()), float(t.std()), float(r.mean()), float(r.std()), t.size, missing
    )
