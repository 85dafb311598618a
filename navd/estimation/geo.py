"""WGS84 fixes into the map frame: UTM projection (pyproj) plus a datum and a rotation.

The map frame is anchored once, to a datum: a WGS84 point and the map position it has. All
fixes are projected into the datum's UTM zone, even beyond the zone's edge, so the map stays
continuous when the robot crosses a zone boundary (the neighbouring zone's grid would be
offset by hundreds of kilometres). Fixes farther from the datum than ``utm_threshold_m``
are refused: no robot drives that far off its map, and such a fix is a receiver fault.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pyproj import Transformer

from navd.estimation.errors import GeoError

__all__ = ["GeoFrame", "MapProjection", "open_projections_here", "utm_zone_for"]


@dataclass(frozen=True, slots=True)
class MapProjection:
    """How the map lies on the UTM grid, as a GeoFrame holds it.

    Attributes:
        map_rotation_rad: [rad] the map's +x axis, counter-clockwise from grid east.
        max_distance_m: [m] fixes farther than this from the datum are refused.
    """

    map_rotation_rad: float
    max_distance_m: float


def utm_zone_for(latitude_deg: float, longitude_deg: float) -> int:
    """The UTM zone (1-60) containing a WGS84 point, with the Norway and Svalbard exceptions."""
    if not (-80.0 <= latitude_deg <= 84.0):
        raise GeoError(f"latitude {latitude_deg} deg is outside UTM's range [-80, 84]")
    lon = ((longitude_deg + 180.0) % 360.0) - 180.0
    zone = int((lon + 180.0) // 6.0) + 1
    zone = min(zone, 60)
    if 56.0 <= latitude_deg < 64.0 and 3.0 <= lon < 12.0:
        return 32
    if latitude_deg >= 72.0 and 0.0 <= lon < 42.0:
        for edge_deg, svalbard_zone in ((9.0, 31), (21.0, 33), (33.0, 35), (42.0, 37)):
            if lon < edge_deg:
                return svalbard_zone
    return zone


def open_projections_here() -> None:
    """Open pyproj's database on the calling thread, before a fix needs it there.

    pyproj keeps one PROJ context, with its open database, per thread. The first frame made
    on a thread opens it, some ten times the cost of a later frame (docs/outdoors.md), and a
    frame made on another thread pays again at its first projection on this one. The daemon
    projects GPS fixes on its event loop, so it calls this there at start.
    """
    Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform(9.0, 0.0)


@dataclass(frozen=True, slots=True)
class _Anchor:
    easting_m: float
    northing_m: float
    map_x_m: float
    map_y_m: float


class GeoFrame:
    """WGS84 <-> map frame through one UTM zone, a datum and the map's rotation.

    Args:
        datum_latitude_deg, datum_longitude_deg: [deg] the anchor point.
        map_rotation_rad: [rad] the map's +x axis, counter-clockwise from grid east.
        zone: UTM zone to use; None picks the datum's own zone.
        datum_map_xy_m: [m] where the datum lies in the map frame (default: the origin).
        max_distance_m: [m] fixes farther than this from the datum are refused.

    Raises:
        GeoError: the datum is outside UTM's latitude range.
    """

    def __init__(
        self,
        datum_latitude_deg: float,
        datum_longitude_deg: float,
        *,
        map_rotation_rad: float,
        zone: int | None,
        datum_map_xy_m: tuple[float, float] = (0.0, 0.0),
        max_distance_m: float,
    ) -> None:
        self.zone = zone or utm_zone_for(datum_latitude_deg, datum_longitude_deg)
        self.south = datum_latitude_deg < 0.0
        epsg = (32700 if self.south else 32600) + self.zone
        self._forward = Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True)
        self._inverse = Transformer.from_crs(f"EPSG:{epsg}", "EPSG:4326", always_xy=True)
        self.map_rotation_rad = map_rotation_rad
        self.max_distance_m = max_distance_m
        self._cos = math.cos(map_rotation_rad)
        self._sin = math.sin(map_rotation_rad)
        easting, northing = self._project(datum_latitude_deg, datum_longitude_deg)
        self._anchor = _Anchor(easting, northing, datum_map_xy_m[0], datum_map_xy_m[1])
        self.datum = (datum_latitude_deg, datum_longitude_deg)
        self.datum_map_xy_m = datum_map_xy_m
        # Grid convergence from a short step north: where true north points on the grid.
        north_e, north_n = self._project(datum_latitude_deg + 1e-4, datum_longitude_deg)
        self.grid_convergence_rad = math.pi / 2.0 - math.atan2(
            north_n - northing, north_e - easting
        )

    @property
    def projection(self) -> MapProjection:
        """The rotation and distance bound this frame was built with."""
        return MapProjection(self.map_rotation_rad, self.max_distance_m)

    def _project(self, latitude_deg: float, longitude_deg: float) -> tuple[float, float]:
        if not (-80.0 <= latitude_deg <= 84.0):
            raise GeoError(f"latitude {latitude_deg} deg is outside UTM's range [-80, 84]")
        easting, northing = self._forward.transform(longitude_deg, latitude_deg)
        if not (math.isfinite(easting) and math.isfinite(northing)):
            raise GeoError(f"({latitude_deg}, {longitude_deg}) cannot be projected to UTM")
        return float(easting), float(northing)

    def to_map(self, latitude_deg: float, longitude_deg: float) -> tuple[float, float]:
        """[m] the map position of a WGS84 point.

        Raises:
            GeoError: the point is farther than ``max_distance_m`` from the datum, or cannot
                be projected.
        """
        easting, northing = self._project(latitude_deg, longitude_deg)
        d_east = easting - self._anchor.easting_m
        d_north = northing - self._anchor.northing_m
        distance = math.hypot(d_east, d_north)
        if distance > self.max_distance_m:
            raise GeoError(
                f"fix ({latitude_deg:.7f}, {longitude_deg:.7f}) is {distance:.0f} m from the "
                f"datum, beyond world.utm_threshold_m ({self.max_distance_m:.0f} m)"
            )
        # Grid offsets into the map frame: rotate by -map_rotation.
        x = self._cos * d_east + self._sin * d_north
        y = -self._sin * d_east + self._cos * d_north
        return x + self._anchor.map_x_m, y + self._anchor.map_y_m

    def to_wgs84(self, x_m: float, y_m: float) -> tuple[float, float]:
        """[deg] (latitude, longitude) of a map position."""
        dx = x_m - self._anchor.map_x_m
        dy = y_m - self._anchor.map_y_m
        d_east = self._cos * dx - self._sin * dy
        d_north = self._sin * dx + self._cos * dy
        lon, lat = self._inverse.transform(
            d_east + self._anchor.easting_m, d_north + self._anchor.northing_m
        )
        return float(lat), float(lon)
