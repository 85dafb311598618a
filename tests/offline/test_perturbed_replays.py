"""The Intel lab replayed with range noise, over several draws of the noise (issue 19).

Kept apart from test_logs_and_relations.py (where the aces replays with lost scans and
worse wheels are) so the test run can give these three replays a worker of their own.
"""

from __future__ import annotations

import statistics
from pathlib import Path

import pytest

from navd.cli import main
from navd.offline.relations import evaluate, read_relations, read_tum
from tests.datasets import dataset

INTEL_BAG_UNPERTURBED_M = 0.0241  # measured with the defaults on 5 December (docs/slam.md)


def test_intel_replay_holds_with_3_cm_of_range_noise_over_three_draws(tmp_path: Path) -> None:
    # Range noise also spreads the heading errors the odometry's weight is learned from; it
    # once lowered the weight until a fast turn slipped and the Intel lab was 3.7 m off.
    # One draw of the noise says little on this log: a loop found a little earlier or later
    # flips a run between holding and losing its way. Seeds 3 and 4 are the draws on which
    # an earlier build lost it (3.9 and 3.7 times its unperturbed 0.0270 m). With the loop
    # window taken through the pose graph but look-alikes checked over the window alone,
    # seed 3 lost it again (0.124 m, 4.6 times). Measured: seeds 0, 3 and 4 1.4, 1.4 and
    # 1.4 times (1.9, 1.5 and 1.6 before the odometry pulled harder along corridors). So: no
    # draw beyond 2.5 times, and the middle one within 2 (docs/slam.md, "Perturbed logs").
    freiburg = dataset("freiburg_slam_benchmark")
    bag = freiburg / "bags_ros1" / "intel.orig.bag"
    relations = read_relations(freiburg / "relations" / "intel.relations")
    means = []
    for seed in (0, 3, 4):
        out = tmp_path / f"seed{seed}"
        args = ["replay", str(bag), "--out", str(out), "--quiet", "--perturb", "noise"]
        assert main([*args, "--seed", str(seed)]) == 0
        stamps, poses = read_tum(out / "trajectory.tum")
        errors = evaluate(stamps, poses, relations)
        assert errors.used == 2984
        means.append(errors.translation_mean_m)
    assert max(means) <= 2.5 * INTEL_BAG_UNPERTURBED_M, means
    assert statistics.median(means) <= 2 * INTEL_BAG_UNPERTURBED_M, means


ACES_UNPERTURBED_M = 0.0395  # measured with the defaults (docs/slam.md)


@pytest.mark.parametrize("kind", ["spurious", "odometry_spikes"])
def test_aces_holds_spurious_returns_and_odometry_spikes(tmp_path: Path, kind: str) -> None:
    # 3 % of the readings at a spurious 80 m; 1 % of the odometry steps jumping 1 m or
    # 1.5 rad (the spikes beyond slam.plausible_* are not followed). Within issue 54's
    # 1.5 times: 0.0415 and 0.0414 m measured. (Intel and fr-clinic do not hold the spikes:
    # docs/slam.md, "The robustness suite".)
    freiburg = dataset("freiburg_slam_benchmark")
    bag = freiburg / "bags_ros1" / "aces.orig.bag"
    args = ["replay", str(bag), "--out", str(tmp_path), "--quiet", "--perturb", kind]
    assert main(args) == 0
    stamps, poses = read_tum(tmp_path / "trajectory.tum")
    errors = evaluate(stamps, poses, read_relations(freiburg / "relations" / "aces.relations"))
    assert errors.used == 1279
    assert errors.translation_mean_m <= 1.5 * ACES_UNPERTURBED_M
