"""The estimator's settings: the estimation, world and mounts sections, as frozen values."""

from __future__ import annotations

from dataclasses import dataclass

from navd.config import BeaconsConfig, EstimationConfig, NavdConfig, WorldConfig
from navd.geometry.mount import SensorMounts

__all__ = ["EstimatorSettings"]


@dataclass(frozen=True, slots=True)
class EstimatorSettings:
    """What the estimator runs on: the estimation and world sections, frozen as they are.

    Attributes:
        estimation: gains, noises, gates, history and localization thresholds.
        world: the geographic frame (datum, UTM zone, map rotation, declination).
        mounts: where the IMU, GNSS antenna and compass sit (by device id).
        beacons: the beacons at known places, and whether to learn the others'.
    """

    estimation: EstimationConfig
    world: WorldConfig
    mounts: SensorMounts
    beacons: BeaconsConfig

    @classmethod
    def from_config(cls, config: NavdConfig) -> EstimatorSettings:
        """The settings the estimation, world, mounts and beacons sections describe."""
        return cls(config.estimation, config.world, SensorMounts.of(config), config.beacons)
