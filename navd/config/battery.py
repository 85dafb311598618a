"""The battery: when its charge is low, and when critical (what the robot does about it is
the missions' and the docks')."""

from __future__ import annotations

from pydantic import Field, model_validator

from navd.config.fields import Section

__all__ = ["BatteryConfig"]


class BatteryConfig(Section):
    """Charge thresholds, in percent of a full battery, as the battery's sensor reports it."""

    low_percent: float = Field(
        20.0, ge=0, le=100, description="[%] at or below this the battery is low (logged, told)"
    )
    critical_percent: float = Field(
        10.0, ge=0, le=100, description="[%] at or below this the battery is critical"
    )
    recover_percent: float = Field(
        5.0,
        ge=0,
        le=50,
        description="[%] an alarm ends only when the charge is this much above its threshold "
        "(a battery's voltage sags under load and recovers at rest)",
    )

    @model_validator(mode="after")
    def _order(self) -> BatteryConfig:
        if self.critical_percent > self.low_percent:
            raise ValueError(
                f"battery.critical_percent ({self.critical_percent}) must not exceed "
                f"battery.low_percent ({self.low_percent})"
            )
        return self
