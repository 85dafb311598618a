"""The estimation room's settings: the estimator's parts' values (the IMU filter, the UKF,
the event history, the map projection) and the sections it reads as they are (estimation,
world, mounts, beacons), derived once; the only place the room reads the config."""

from __future__ import annotations

from dataclasses import dataclass

from navd.config import BeaconsConfig, EstimationConfig, NavdConfig, WorldConfig
from navd.estimation.geo import MapProjection
from navd.estimation.history import HistorySettings
from navd.estimation.madgwick import MadgwickSettings
from navd.estimation.ukf import UkfSettings
from navd.geometry import SensorMounts

__all__ = ["EstimatorSettings"]


@dataclass(frozen=True, slots=True)
class EstimatorSettings:
    """What the estimator runs on: the estimation and world sections, frozen as they are.

    Attributes:
        estimation: gains, noises, gates, history and localization thresholds.
        world: the geographic frame (datum, UTM zone, map rotation, declination).
        mounts: where the IMU, GNSS antenna and compass sit (by device id).
        beacons: the beacons at known places, and whether to learn the others'.
        madgwick, ukf, history, projection: the parts' own values.
        publish_period_s: [s] how often the pose is published (needs a restart).
    """

    estimation: EstimationConfig
    world: WorldConfig
    mounts: SensorMounts
    beacons: BeaconsConfig
    madgwick: MadgwickSettings
    ukf: UkfSettings
    history: HistorySettings
    projection: MapProjection
    publish_period_s: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> EstimatorSettings:
        """The settings the estimation, world, mounts, lidar and beacons sections describe."""
        est, world = config.estimation, config.world
        return cls(
            estimation=est,
            world=world,
            mounts=SensorMounts.of(config.mounts, config.lidar),
            beacons=config.beacons,
            madgwick=MadgwickSettings.of(est),
            ukf=UkfSettings.of(est),
            history=HistorySettings.of(est),
            projection=MapProjection(world.map_rotation_rad, world.utm_threshold_m),
            publish_period_s=1.0 / est.publish_rate_hz,
        )
