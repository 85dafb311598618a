"""Where the shared public datasets are: $NAVD_DATASETS, else ../shared/datasets by the clone."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def dataset(name: str) -> Path:
    """The folder of dataset ``name``; skips the test, saying why, when it is absent."""
    root = Path(os.environ.get("NAVD_DATASETS", REPO.parent / "shared" / "datasets"))
    folder = root / name
    if not folder.is_dir():
        pytest.skip(
            f"dataset {name!r} not found at {folder}: it lives in ../shared/datasets beside "
            "the clone (CI has it); set NAVD_DATASETS to point elsewhere"
        )
    return folder
