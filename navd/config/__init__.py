"""The one TOML configuration, validated by pydantic: load, check, change, dump."""

from navd.config.errors import ConfigError
from navd.config.loader import apply_changes, dump_toml, load_config, parse_config
from navd.config.model import (
    ChassisConfig,
    EstimationConfig,
    LidarConfig,
    LifecycleConfig,
    LoggingConfig,
    NavdConfig,
    PlanningConfig,
    RobotConfig,
    SafetyConfig,
    SlamConfig,
    TcpConfig,
    WorldConfig,
)

__all__ = [
    "ChassisConfig",
    "ConfigError",
    "EstimationConfig",
    "LidarConfig",
    "LifecycleConfig",
    "LoggingConfig",
    "NavdConfig",
    "PlanningConfig",
    "RobotConfig",
    "SafetyConfig",
    "SlamConfig",
    "TcpConfig",
    "WorldConfig",
    "apply_changes",
    "dump_toml",
    "load_config",
    "parse_config",
]
