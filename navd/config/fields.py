"""What every config section is made of: the strict, frozen ``Section``; the field marks
(needs a restart, holds a secret); the shared value types; and which keys are privileged,
changed by control clients only where the config grants it."""

from __future__ import annotations

import ipaddress
from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict

__all__ = [
    "MAP_NAME_PATTERN",
    "PRIVILEGED",
    "STANDARD_BAUD_RATES",
    "Point2",
    "Polygon",
    "Polygons",
    "Section",
    "Table",
    "is_loopback",
    "is_secret",
    "privileged",
    "restart",
    "restart_required",
]

STANDARD_BAUD_RATES = (9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600)
# A file name in map_dir: no separators, not hidden, not "." or "..".
MAP_NAME_PATTERN = r"^[A-Za-z0-9_][A-Za-z0-9_.\-]{0,63}$"


def _lists_to_tuples(value: Any) -> Any:
    """TOML arrays arrive as lists; the frozen model stores tuples."""
    if isinstance(value, list):
        return tuple(_lists_to_tuples(item) for item in value)
    return value


Point2 = tuple[float, float]
Polygon = Annotated[tuple[Point2, ...], BeforeValidator(_lists_to_tuples)]
Table = Annotated[tuple[Point2, ...], BeforeValidator(_lists_to_tuples)]
Polygons = Annotated[tuple[Polygon, ...], BeforeValidator(_lists_to_tuples)]
Vector2 = Annotated[Point2, BeforeValidator(_lists_to_tuples)]
Matrix2 = Annotated[tuple[Point2, Point2], BeforeValidator(_lists_to_tuples)]


def restart(description: str, *, secret: bool = False) -> dict[str, Any]:
    """Field keyword arguments marking a field that only takes effect at start-up (and, with
    ``secret``, one whose value is never logged or echoed in an error)."""
    return {"description": description, "json_schema_extra": {"restart": True, "secret": secret}}


# Keys that decide how safely the robot moves, where files go and how the daemon guards
# itself: a control client may change them only where tcp.allow_privileged_changes says so
# (the config file, and SIGHUP re-reading it, always may). None: every key of the section.
PRIVILEGED: dict[str, frozenset[str] | None] = {
    "safety": None,
    "chassis": None,
    "tcp": None,
    "teleop": None,
    "lifecycle": None,
    "lidar": None,
    "robot": frozenset(
        {
            "footprint",
            "radius_m",
            "length_m",
            "width_m",
            "track_width_m",
            "max_linear_speed_mps",
            "max_reverse_speed_mps",
            "max_angular_speed_radps",
            "max_linear_accel_mps2",
            "max_angular_accel_radps2",
        }
    ),
    "slam": frozenset({"map_dir", "map_name"}),
    "record": frozenset({"dir", "budget_mb", "max_file_mb"}),
    "planning": frozenset(
        {
            "keep_out_zones",
            "keep_out_mask",
            "speed_mask",
            "max_goal_distance_m",
            "max_plan_cells",
            # what each control step costs
            "control_rate_hz",
            "linear_samples",
            "angular_samples",
            "prediction_horizon_s",
            "sim_step_s",
        }
    ),
    "estimation": frozenset({"degraded_position_std_m", "lost_position_std_m"}),
}


def privileged(section: str, field: str) -> bool:
    """True if ``section.field`` is a privileged key (see PRIVILEGED)."""
    keys = PRIVILEGED.get(section, frozenset())
    return keys is None or field in keys


def is_loopback(host: str) -> bool:
    """True if ``host`` (an address or ``localhost``) reaches only this machine."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def is_secret(model: type[BaseModel], field: str) -> bool:
    """True if ``field`` of ``model`` holds a secret."""
    extra = model.model_fields[field].json_schema_extra
    return isinstance(extra, dict) and bool(extra.get("secret"))


def restart_required(model: type[BaseModel], field: str) -> bool:
    """True if ``field`` of ``model`` cannot be changed while the daemon runs."""
    extra = model.model_fields[field].json_schema_extra
    return isinstance(extra, dict) and bool(extra.get("restart"))


class Section(BaseModel):
    """Common settings of every config section."""

    model_config = ConfigDict(
        strict=True, extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False
    )
