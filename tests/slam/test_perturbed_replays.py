"""`navd replay --perturb` on a shared log: the defaults hold under a worse sensor (issue 19).

Kept apart from test_logs_and_relations.py so the test run can give these replays a worker
of their own.
"""

from __future__ import annotations

import statistics
from pathlib import Path

from navd.cli import main
from navd.slam.relations import evaluate, read_relations, read_tum
from tests.datasets import dataset

INTEL_BAG_UNPERTURBED_M = 0.0273  # measured with the defaults on 4 December (docs/slam.md)


def test_intel_replay_holds_with_3_cm_of_range_noise_whatever_the_noise_draws(
    tmp_path: Path,
) -> None:
    # Range noise also spreads the heading errors the odometry's weight is learned from; it
    # once lowered the weight until a fast turn slipped and the Intel lab was lost (3.7 m).
    # One draw of the noise says little on this log: a loop found a little earlier or later
    # flips a run between holding and losing its way (the build before held seed 0 at 1.6
    # times and lost seeds 3 and 4 at 3.8 and 3.7). Three draws: none lost (2.5 times), and
    # the middle one within issue 19's two times.
    freiburg = dataset("freiburg_slam_benchmark")
    bag = freiburg / "bags_ros1" / "intel.orig.bag"
    relations = read_relations(freiburg / "relations" / "intel.relations")
    means = []
    for seed in (0, 1, 2):
        out = tmp_path / f"seed{seed}"
        args = ["replay", str(bag), "--out", str(out), "--quiet", "--perturb", "noise"]
        assert main([*args, "--seed", str(seed)]) == 0
        stamps, poses = read_tum(out / "trajectory.tum")
        errors = evaluate(stamps, poses, relations)
        assert errors.used == 2984
        means.append(errors.translation_mean_m)
    assert max(means) <= 2.5 * INTEL_BAG_UNPERTURBED_M, means
    assert statistics.median(means) <= 2 * INTEL_BAG_UNPERTURBED_M, means
