"""The map's place on the earth: the geographic frame GNSS fixes are projected through,
anchored at the configured datum (``world.datum_latitude_deg`` ...) or, without one, at the
first fix good enough (``estimation.datum_max_accuracy_m``), where the robot then stood."""

from __future__ import annotations

from navd.config import WorldConfig
from navd.estimation.geo import GeoFrame

__all__ = ["GeoAnchor"]


class GeoAnchor:
    """The geographic frame of the map, or None before a datum is known.

    Args:
        world: the world section (datum, UTM zone, map rotation, UTM threshold).

    Raises:
        GeoError: the configured datum cannot be projected.
    """

    def __init__(self, world: WorldConfig) -> None:
        self.world = world
        self.frame: GeoFrame | None = None
        if world.datum_latitude_deg is not None and world.datum_longitude_deg is not None:
            self.frame = self._frame(world.datum_latitude_deg, world.datum_longitude_deg)

    def configure(self, world: WorldConfig) -> None:
        """Take a new world section: the frame at the configured datum, or (without one) at
        the datum the first good fix set, in the new frame.

        Raises:
            GeoError: the new datum cannot be projected (nothing changes).
        """
        if world == self.world:
            return
        frame = self.frame
        if world.datum_latitude_deg is not None and world.datum_longitude_deg is not None:
            frame = self._frame(world.datum_latitude_deg, world.datum_longitude_deg, world=world)
        elif frame is not None:
            frame = self._frame(*frame.datum, frame.datum_map_xy_m, world=world)
        self.world, self.frame = world, frame

    def anchor(self, latitude_deg: float, longitude_deg: float, at_xy: tuple[float, float]) -> None:
        """Put the datum at WGS84 (``latitude_deg``, ``longitude_deg``), map point ``at_xy``
        [m].

        Raises:
            GeoError: the place cannot be projected (nothing changes).
        """
        self.frame = self._frame(latitude_deg, longitude_deg, at_xy)

    def _frame(
        self,
        latitude_deg: float,
        longitude_deg: float,
        at_xy: tuple[float, float] = (0.0, 0.0),
        *,
        world: WorldConfig | None = None,
    ) -> GeoFrame:
        world = world or self.world
        return GeoFrame(
            latitude_deg,
            longitude_deg,
            map_rotation_rad=world.map_rotation_rad,
            zone=world.utm_zone,
            datum_map_xy_m=at_xy,
            max_distance_m=world.utm_threshold_m,
        )
