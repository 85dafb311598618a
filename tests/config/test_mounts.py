"""The mounts section: device ids as table names, one kind per id, strict values."""

from __future__ import annotations

import re

import pytest
from pydantic import ValidationError

from navd.config import NavdConfig


@pytest.mark.parametrize(
    ("mounts", "named"),
    [
        ({"lidars": {"bad id!": {}}}, "mounts.lidars.bad id!"),
        ({"lidars": {"a": {}}, "gps": {"a": {}}}, "also under mounts.lidars"),
        ({"lidars": {"a": {"x_m": "0.2"}}}, "x_m"),
        ({"lidars": {"a": {"height_m": 0.2}}}, "height_m"),
        ({"gps": {"g": {"x_m": 9.0}}}, "x_m"),
    ],
)
def test_a_bad_mount_is_refused_by_name(mounts: dict[str, object], named: str) -> None:
    with pytest.raises(ValidationError, match=re.escape(named)):
        NavdConfig.model_validate({"mounts": mounts})
