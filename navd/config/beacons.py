"""Beacons as landmarks: where the known ones stand, and learning where the others do.

A beacon is anything a sensor program can measure a range or a bearing to and name: a UWB
anchor, an AprilTag, a BLE tag, a reflector post. One at a known place (``[beacons.known.ID]``)
localizes the robot: its ranges and bearings are fused in the state estimator. One that is
not listed has its place learnt from the bearings to it as the robot moves (a Kalman filter
per beacon); a learnt place is a goal for missions ("go to beacon", "visit all beacons"),
never used to localize (the robot would be chasing its own estimate).
"""

from __future__ import annotations

import re

from pydantic import Field, model_validator

from navd.config.fields import Section, restart

__all__ = ["BeaconPlaceConfig", "BeaconsConfig"]

# The beacon ids a sensor may name (the protocol's device id pattern, repeated: config sits
# below the protocol).
_BEACON_ID = re.compile(r"^[A-Za-z0-9_.:\-]{1,64}$")
_FAR_M = 1e6


class BeaconPlaceConfig(Section):
    """Where a beacon stands in the map frame."""

    x_m: float = Field(ge=-_FAR_M, le=_FAR_M, description="[m] the beacon's x in the map frame")
    y_m: float = Field(ge=-_FAR_M, le=_FAR_M, description="[m] the beacon's y in the map frame")


class BeaconsConfig(Section):
    """Beacons by id: ``[beacons.known.anchor1]`` with ``x_m`` and ``y_m``."""

    known: dict[str, BeaconPlaceConfig] = Field(
        default_factory=dict,
        examples=[{"anchor1": {"x_m": 0.0, "y_m": 0.0}, "anchor2": {"x_m": 10.0, "y_m": 0.0}}],
        **restart(
            "beacons at known places, by the id their sensor names them with: their ranges and "
            "bearings localize the robot"
        ),
    )
    learn: bool = Field(
        True,
        description="learn the places of beacons not listed from the bearings to them (goals "
        "for missions, not used to localize)",
    )
    gate_chi2: float = Field(
        10.8,
        gt=0,
        le=1e6,
        description="[chi2] Mahalanobis gate of one beacon's range and bearing (a reflection or "
        "a blocked line of sight is refused)",
    )

    @model_validator(mode="after")
    def _ids(self) -> BeaconsConfig:
        for beacon_id in self.known:
            if not _BEACON_ID.match(beacon_id):
                raise ValueError(
                    f"beacons.known.{beacon_id}: a beacon id is 1-64 letters, digits and _ . : -"
                )
        return self
