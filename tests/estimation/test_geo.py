"""WGS84 -> map frame: zones, datum, rotation, zone edges and refusal of far fixes."""

from __future__ import annotations

import math

import pytest
from pyproj import Geod

from navd.estimation.errors import GeoError
from navd.estimation.geo import GeoFrame, utm_zone_for

GEOD = Geod(ellps="WGS84")


@pytest.mark.parametrize(
    ("lat", "lon", "zone"),
    [
        (52.52, 13.405, 33),
        (0.0, -180.0, 1),
        (0.0, 179.99, 60),
        (-33.9, 18.4, 34),
        (60.0, 5.0, 32),
        (60.0, 2.0, 31),
        (78.0, 15.0, 33),
        (78.0, 8.0, 31),
        (78.0, 30.0, 35),
    ],
)
def test_utm_zone_including_norway_and_svalbard(lat: float, lon: float, zone: int) -> None:
    assert utm_zone_for(lat, lon) == zone


def test_zone_outside_utm_latitudes_is_refused() -> None:
    with pytest.raises(GeoError, match=r"latitude 85.0 deg is outside UTM's range"):
        utm_zone_for(85.0, 0.0)


def _frame(lat: float, lon: float, rotation: float = 0.0, **kw: object) -> GeoFrame:
    return GeoFrame(lat, lon, map_rotation_rad=rotation, zone=None, max_distance_m=1e4, **kw)  # type: ignore[arg-type]


def test_datum_is_the_origin_and_north_is_plus_y() -> None:
    frame = _frame(52.52, 13.405)
    assert frame.to_map(52.52, 13.405) == pytest.approx((0.0, 0.0), abs=1e-6)
    lon, lat, _ = GEOD.fwd(13.405, 52.52, 0.0, 100.0)  # 100 m due true north
    x, y = frame.to_map(lat, lon)
    # Grid north differs from true north by the convergence; the distance is kept to the
    # UTM scale factor (within 0.1 %).
    assert math.hypot(x, y) == pytest.approx(100.0, rel=1e-3)
    assert math.atan2(x, y) == pytest.approx(frame.grid_convergence_rad, abs=1e-4)


def test_map_rotation_and_datum_position() -> None:
    frame = _frame(52.52, 13.405, rotation=math.pi / 2, datum_map_xy_m=(5.0, -2.0))
    lon, lat, _ = GEOD.fwd(13.405, 52.52, 90.0 - math.degrees(frame.grid_convergence_rad), 50.0)
    x, y = frame.to_map(lat, lon)  # 50 m grid-east: with map +x pointing north, that is -y
    assert (x, y) == pytest.approx((5.0, -52.0), abs=0.05)
    assert frame.to_wgs84(x, y) == pytest.approx((lat, lon), abs=1e-9)


def test_crossing_a_zone_edge_keeps_the_map_continuous() -> None:
    frame = _frame(48.0, 11.999)  # zone 32, 76 m west of the edge with zone 33
    assert frame.zone == 32
    lon, lat, _ = GEOD.fwd(11.999, 48.0, 90.0, 150.0)  # now in zone 33
    assert utm_zone_for(lat, lon) == 33
    x, y = frame.to_map(lat, lon)
    assert math.hypot(x, y) == pytest.approx(150.0, rel=1e-3)


def test_fix_beyond_the_threshold_is_refused_by_name() -> None:
    frame = _frame(52.52, 13.405)
    with pytest.raises(GeoError, match=r"beyond world.utm_threshold_m \(10000 m\)"):
        frame.to_map(52.7, 13.405)
