"""The missions room's settings: the beacons whose places the config gives (a mission can
visit them before the estimator publishes them with the learnt ones); the only place the
room reads the config."""

from __future__ import annotations

from dataclasses import dataclass

from navd.config import NavdConfig

__all__ = ["MissionSettings"]


@dataclass(frozen=True, slots=True)
class MissionSettings:
    """What missions start from.

    Attributes:
        beacon_places: [m] the known beacons' (id, x, y) in the map frame.
    """

    beacon_places: tuple[tuple[str, float, float], ...]

    def places(self) -> dict[str, tuple[float, float]]:
        """[m] the known beacons' places by id."""
        return {b: (x, y) for b, x, y in self.beacon_places}

    @classmethod
    def from_config(cls, config: NavdConfig) -> MissionSettings:
        """The settings the beacons section describes."""
        known = config.beacons.known
        return cls(tuple((b, p.x_m, p.y_m) for b, p in known.items()))
