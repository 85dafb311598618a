"""The robot's state (``RobotState``) as the live view's JSON: ``/status`` (safety, who
drives, localization, the battery, the daemon's health) and ``/goal_status`` (the goal's progress).
A number not known (NaN) is left out, as the channels' schemas say (``view_schemas``: a
viewer reads no null)."""

from __future__ import annotations

import math
from typing import Any

from navd.lifecycle.messages import GoalStatus, RobotState

__all__ = ["STATUS_PARTS", "goal_status_message", "status_message"]

# The parts of the robot's state that /status shows: a change of any other is not sent.
STATUS_PARTS = frozenset({"daemon", "localization", "mode", "safety", "battery"})


def _known(**values: float | bool | None) -> dict[str, float | bool]:
    """The values that are known: not None, not NaN or infinite."""
    return {
        name: value
        for name, value in values.items()
        if value is not None and (isinstance(value, bool) or math.isfinite(value))
    }


def status_message(state: RobotState) -> dict[str, Any]:
    """/status: what holds the robot, who drives, how well it is localized, the battery,
    the daemon."""
    message: dict[str, Any] = {
        "safety": {"stopped": bool(state.held), "reasons": list(state.held)},
    }
    if state.mode is not None:
        message["drive"] = {"mode": state.mode.mode, "operator": state.mode.operator}
    localization = state.localization
    if localization is not None:
        message["localization"] = {
            "state": localization.state,
            **_known(
                position_std_m=localization.position_std_m, yaw_std_rad=localization.yaw_std_rad
            ),
        }
    battery = state.battery
    if battery is not None:
        message["battery"] = {
            "voltage_v": round(battery.voltage_v, 3),
            "alarm": state.battery_alarm,
            **_known(
                current_a=battery.current_a,
                percentage=battery.percentage,
                charging=battery.charging,
            ),
        }
    daemon = state.daemon
    if daemon is not None:
        message.update(
            stamp=daemon.stamp,
            uptime_s=round(daemon.uptime_s, 3),
            loop_lag_max_ms=round(daemon.loop_lag_max_ms, 3),
            safe_stop_reasons=list(daemon.safe_stop_reasons),
            modules=[
                {
                    "name": m.name,
                    "state": m.state,
                    "faulted": m.faulted,
                    "failures": m.handler_failures,
                }
                for m in daemon.modules
            ],
        )
    return message


def goal_status_message(status: GoalStatus) -> dict[str, Any]:
    """/goal_status: the goal, its state, the distance and time left, why it ended."""
    return {
        "stamp": status.stamp,
        "goal_id": status.goal_id,
        "state": status.state,
        "reason": status.reason,
        **_known(distance_remaining_m=status.distance_remaining_m, eta_s=status.eta_s),
    }
