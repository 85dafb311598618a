"""The BARN benchmark harness on the real dataset (skipped without ../shared)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.sim.barn import (
    _run,
    jackal_config,
    load_cylinders,
    reference_length_m,
    run_barn,
    run_world,
)
from navd.sim.errors import SimError
from tests.datasets import dataset


def test_the_official_score_formula() -> None:
    # T* = 12 / 2 = 6 s: 10 s scores 6/12 (clipped to 2 T*), 30 s scores 6/30, 60 s 6/48.
    assert _run(1, True, False, False, 10.0, 12.0).score == pytest.approx(0.5)
    assert _run(1, True, False, False, 30.0, 12.0).score == pytest.approx(0.2)
    assert _run(1, True, False, False, 60.0, 12.0).score == pytest.approx(6 / 48)
    assert _run(1, False, True, False, 10.0, 12.0).score == 0.0


def test_a_missing_dataset_is_named(tmp_path) -> None:
    with pytest.raises(SimError, match=r"barn_cylinders\.csv\.gz not found"):
        run_barn(tmp_path)


def test_two_worlds_are_driven_without_collision() -> None:
    barn = dataset("barn")
    cylinders = load_cylinders(barn)
    assert len(cylinders) == 200 and 1 in cylinders
    # World 1's reference path: 31..47 cells of 0.15 m plus the way in and out.
    assert 10.0 < reference_length_m(barn, 1) < 16.0
    assert np.all(np.isfinite(cylinders[1]))
    summary = run_barn(barn, worlds=[1, 2], config=jackal_config())
    assert summary["worlds"] == 2
    assert summary["collision"] == 0.0
    assert summary["success"] == 1.0
    assert 0.0 < summary["mean_score"] <= 0.5 and not math.isnan(summary["mean_score"])


def test_backing_out_never_hits_what_the_lidar_saw_before() -> None:
    # World 214 once got stuck, backed out and hit a cylinder behind it, outside the 270°
    # lidar's view now but seen on the way in: the remembered scan obstacles stop that.
    barn = dataset("barn")
    run = run_world(214, load_cylinders(barn)[214], reference_length_m(barn, 214), jackal_config())
    assert not run.collided
