"""The estimator's settings: the estimation and world sections, as frozen values."""

from __future__ import annotations

from dataclasses import dataclass

from navd.config import EstimationConfig, NavdConfig, WorldConfig

__all__ = ["EstimatorSettings"]


@dataclass(frozen=True, slots=True)
class EstimatorSettings:
    """What the estimator runs on: the estimation and world sections, frozen as they are.

    Attributes:
        estimation: gains, noises, gates, history and localization thresholds.
        world: the geographic frame (datum, UTM zone, map rotation, declination).
    """

    estimation: EstimationConfig
    world: WorldConfig

    @classmethod
    def from_config(cls, config: NavdConfig) -> EstimatorSettings:
        """The settings the estimation and world sections describe."""
        return cls(config.estimation, config.world)
