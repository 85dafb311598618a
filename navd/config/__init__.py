"""The one TOML configuration, validated by pydantic: load, check, change, dump."""

from navd.config.battery import BatteryConfig
from navd.config.beacons import BeaconPlaceConfig, BeaconsConfig
from navd.config.body import ChassisConfig, LidarConfig, RobotConfig, SafetyConfig
from navd.config.edit import set_table_keys
from navd.config.errors import ConfigError
from navd.config.fields import is_loopback
from navd.config.fleet import FleetConfig, split_broker_url
from navd.config.loader import (
    apply_changes,
    changed_keys,
    check_runtime_changeable,
    dump_toml,
    load_config,
    parse_config,
    toml_key,
)
from navd.config.localization import EstimationConfig, SlamConfig, WorldConfig
from navd.config.model import NavdConfig
from navd.config.mounts import (
    CompassMountConfig,
    GpsMountConfig,
    ImuMountConfig,
    LidarMountConfig,
    MountsConfig,
)
from navd.config.planning import PlanningConfig
from navd.config.record import RecordConfig
from navd.config.redaction import redacted, redacted_changes
from navd.config.service import LifecycleConfig, LoggingConfig, TcpConfig
from navd.config.teleop import TeleopConfig
from navd.config.viz import VizConfig

__all__ = [
    "BatteryConfig",
    "BeaconPlaceConfig",
    "BeaconsConfig",
    "ChassisConfig",
    "CompassMountConfig",
    "ConfigError",
    "EstimationConfig",
    "FleetConfig",
    "GpsMountConfig",
    "ImuMountConfig",
    "LidarConfig",
    "LidarMountConfig",
    "LifecycleConfig",
    "LoggingConfig",
    "MountsConfig",
    "NavdConfig",
    "PlanningConfig",
    "RecordConfig",
    "RobotConfig",
    "SafetyConfig",
    "SlamConfig",
    "TcpConfig",
    "TeleopConfig",
    "VizConfig",
    "WorldConfig",
    "apply_changes",
    "changed_keys",
    "check_runtime_changeable",
    "dump_toml",
    "is_loopback",
    "load_config",
    "parse_config",
    "redacted",
    "redacted_changes",
    "set_table_keys",
    "split_broker_url",
    "toml_key",
]
