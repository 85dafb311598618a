"""Typed messages: the only way modules talk to each other.

Every message is a small frozen value. ``stamp`` is the time of measurement (or of the
decision, for messages a module publishes) and ``received`` the time it reached the daemon,
both in seconds on the daemon's clock (see ``navd.lifecycle.clock``). Conventions follow
ROS: SI units, right-handed frames, x forward, y left, z up, yaw counter-clockwise from +x.

Arrays inside messages are copied and made read-only, so a message cannot change after it
was published. Construction checks only what is cheap and always wrong (a negative range
limit, a NaN stamp); wire-level validation lives in the drivers.
"""

from navd.lifecycle.messages.base import DeviceKind, Message, Vector3, describe
from navd.lifecycle.messages.control import (
    CancelGoal,
    ConfigApplied,
    ConfigChange,
    ConfigRejected,
    DriveCommand,
    DriveMode,
    GeoGoal,
    Goal,
    GoalStatus,
    InitialPose,
    ManualCommand,
    MapSaved,
    RecordingState,
    RecordRequest,
    SafeStop,
    SafeStopCleared,
    SafetyState,
    SaveMapRequest,
    VelocityCommand,
    ViewInterest,
)
from navd.lifecycle.messages.results import (
    CostmapUpdate,
    DaemonStatus,
    LocalizationState,
    LocalTrajectory,
    MapUpdate,
    ModuleHealth,
    Orientation,
    Path,
    PoseEstimate,
    PoseMeasurement,
    StuckDetected,
    WorkerStats,
)
from navd.lifecycle.messages.sensors import (
    CompassHeading,
    DeviceConnected,
    DeviceLost,
    DeviceResumed,
    DeviceStale,
    GpsFix,
    Imu,
    LaserScan,
    WheelOdometry,
)

__all__ = [
    "CancelGoal",
    "CompassHeading",
    "ConfigApplied",
    "ConfigChange",
    "ConfigRejected",
    "CostmapUpdate",
    "DaemonStatus",
    "DeviceConnected",
    "DeviceKind",
    "DeviceLost",
    "DeviceResumed",
    "DeviceStale",
    "DriveCommand",
    "DriveMode",
    "GeoGoal",
    "Goal",
    "GoalStatus",
    "GpsFix",
    "Imu",
    "InitialPose",
    "LaserScan",
    "LocalTrajectory",
    "LocalizationState",
    "ManualCommand",
    "MapSaved",
    "MapUpdate",
    "Message",
    "ModuleHealth",
    "Orientation",
    "Path",
    "PoseEstimate",
    "PoseMeasurement",
    "RecordRequest",
    "RecordingState",
    "SafeStop",
    "SafeStopCleared",
    "SafetyState",
    "SaveMapRequest",
    "StuckDetected",
    "Vector3",
    "VelocityCommand",
    "ViewInterest",
    "WheelOdometry",
    "WorkerStats",
    "describe",
]
