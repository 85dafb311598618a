"""The battery's alarms: ``BatteryAlarm`` when its charge falls to ``battery.low_percent``
or ``battery.critical_percent``, logged once, and again when it has recovered
``battery.recover_percent`` above (a battery's voltage sags under load and recovers at rest:
the margin keeps a robot on the edge from telling it every second). A reading without a
charge (a sensor that knows only the voltage) changes nothing."""

from __future__ import annotations

import math
from typing import Literal

from navd.lifecycle.daemon_settings import BatteryLevels
from navd.lifecycle.messages import BatteryAlarm, BatteryState
from navd.lifecycle.module import Module, ModuleContext

__all__ = ["BatteryWatch", "alarm_level"]

Level = Literal["ok", "low", "critical"]


def alarm_level(percentage: float, level: Level, levels: BatteryLevels) -> Level:
    """The alarm for a charge of ``percentage`` [0, 1], given the one in force: a threshold
    reached counts at once, one left only ``recover`` above it."""
    if percentage <= levels.critical:
        return "critical"
    if level == "critical" and percentage <= levels.critical + levels.recover:
        return "critical"
    if percentage <= levels.low:
        return "low"
    if level != "ok" and percentage <= levels.low + levels.recover:
        return "low"
    return "ok"


class BatteryWatch(Module):
    """Hears the battery's state and says when its alarm changes."""

    def __init__(self) -> None:
        super().__init__("battery")
        self.level: Level = "ok"

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.levels = ctx.settings(BatteryLevels.from_config)
        ctx.subscribe(BatteryState, self._on_battery)

    def settings_in_use(self) -> tuple[object, ...]:
        return (self.levels.value,)

    def _on_battery(self, battery: BatteryState) -> None:
        if math.isnan(battery.percentage):
            return
        level = alarm_level(battery.percentage, self.level, self.levels.value)
        if level == self.level:
            return
        self.level = level
        percent = round(battery.percentage * 100.0, 1)
        log = self.ctx.log.info if level == "ok" else self.ctx.log.warning
        log("battery_" + level, percent=percent, device_id=battery.device_id)
        self.ctx.publish(
            BatteryAlarm(
                stamp=battery.stamp,
                received=battery.received,
                level=level,
                percentage=battery.percentage,
            )
        )
