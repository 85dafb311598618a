"""What every config section is made of: the strict, frozen ``Section``; the field marks
(needs a restart, holds a secret); the shared value types; and which keys are privileged,
changed by control clients only where the config grants it."""

from __future__ import annotations

import ipaddress
from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict

__all__ = [
    "MAP_NAME_PATTERN",
    "OPERATOR_KEYS",
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


# The keys a control client may change without tcp.allow_privileged_changes: those that
# change how the robot reports, records and picks its way, never how safely it moves, what it
# believes about where it is, or who may command it. Every other key is privileged: a key is
# privileged unless it is shown harmless here (the config file, and SIGHUP re-reading it,
# always may change any key).
OPERATOR_KEYS: dict[str, frozenset[str]] = {
    "robot": frozenset({"name"}),
    "slam": frozenset({"updating_map", "save_on_shutdown"}),
    "planning": frozenset(
        {
            # route and trajectory preferences: the guard and the safety gate bound them all
            "goal_weight",
            "path_weight",
            "heading_weight",
            "oscillation_weight",
            "cost_weight",
            "smooth_path",
            "goal_xy_tolerance_m",
            "goal_yaw_tolerance_rad",
            "replan_period_s",
            "approach_distance_m",
            "lookahead_m",
            "max_path_deviation_m",
        }
    ),
    "logging": frozenset({"level", "status_log_period_s"}),
    "viz": frozenset({"map_rate_hz", "scan_rate_hz", "pose_rate_hz", "log_level"}),
    "record": frozenset({"flush_period_s", "map_period_s"}),
    "fleet": frozenset({"state_interval_s", "visualization_rate_hz"}),
}


def privileged(section: str, field: str) -> bool:
    """True if ``section.field`` is a privileged key: any key not in OPERATOR_KEYS."""
    return field not in OPERATOR_KEYS.get(section, frozenset())


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
