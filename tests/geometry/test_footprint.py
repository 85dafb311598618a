"""The footprint: circle or rectangle, its inscribed and circumscribed radii."""

from __future__ import annotations

import pytest

from navd.config import NavdConfig
from navd.geometry.footprint import CIRCLE, RECTANGLE, Footprint


@pytest.mark.parametrize(
    ("robot", "kind", "inscribed", "circumradius"),
    [
        ({"footprint": "circle", "radius_m": 0.25}, CIRCLE, 0.25, 0.25),
        ({"footprint": "rectangle", "length_m": 0.6, "width_m": 0.8}, RECTANGLE, 0.3, 0.5),
        ({"footprint": "rectangle", "length_m": 0.4, "width_m": 0.3}, RECTANGLE, 0.15, 0.25),
    ],
)
def test_the_robot_section_gives_the_footprint(
    robot: dict[str, object], kind: int, inscribed: float, circumradius: float
) -> None:
    fp = Footprint.of(NavdConfig.model_validate({"robot": robot}).robot)
    assert fp.kind == kind
    assert fp.inscribed_m == pytest.approx(inscribed)
    assert fp.circumradius_m == pytest.approx(circumradius)
