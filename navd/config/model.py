"""The configuration model: one pydantic section per subsystem, combined in ``NavdConfig``.

Every model is strict (a string is never read as a number), forbids unknown keys, and is
frozen, so the running config can only be replaced whole. Every number has bounds and a
description that starts with its unit. Fields marked ``restart`` cannot change at runtime.
The runtime-changeable fields follow the seed's ConfigProperty: updating_map,
use_collisions, reaction timeout, collision distance, and the planner, noise,
localization, matching, sensor, stuck and metrics parameters; the seed's UseDebug is
``logging.level = "debug"``.
"""

from __future__ import annotations

import ipaddress
import itertools
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator

__all__ = [
    "ChassisConfig",
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
    "is_secret",
    "privileged",
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
    "planning": frozenset(
        {
            "keep_out_zones",
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


class LifecycleConfig(Section):
    """The event loop, dispatch, workers and supervision."""

    event_loop: Literal["uvloop", "asyncio"] = Field(
        "uvloop",
        **restart(
            "uvloop (libuv; about 3x less CPU per socket wakeup here) or the standard asyncio loop"
        ),
    )
    clock: Literal["real", "simulated"] = Field(
        "real",
        **restart(
            "real (the monotonic clock) or simulated (time stands still until a clock client, "
            "a simulator, moves it in lockstep; see docs/simulator.md)"
        ),
    )
    lockstep_timeout_s: float = Field(
        5.0,
        gt=0,
        le=600,
        description="[s] real time a simulated-clock step waits for the lines the simulator "
        "says it sent before going ahead without them (logged)",
    )
    worker_threads: int = Field(
        2, ge=1, le=16, **restart("[threads] worker threads for heavy jobs (scan matching, A*)")
    )
    transition_timeout_s: float = Field(
        5.0, gt=0, le=120, description="[s] longest a module may take to start or stop"
    )
    status_rate_hz: float = Field(
        1.0, gt=0, le=50, description="[Hz] how often the daemon publishes its status"
    )
    lag_sample_period_s: float = Field(
        0.05, ge=0.001, le=1.0, description="[s] period of the event-loop lag probe"
    )
    lag_window: int = Field(
        1200, ge=10, le=100_000, **restart("[samples] lag samples kept for the percentiles")
    )
    handler_budget_ms: float = Field(
        1.0, gt=0, le=1000, description="[ms] a handler taking longer is counted as slow"
    )
    max_handler_failures: int = Field(
        5,
        ge=1,
        le=10_000,
        description="[count] failures within failure_window_s that fault a module",
    )
    failure_window_s: float = Field(
        10.0, gt=0, le=3600, description="[s] window over which handler failures are counted"
    )
    max_dispatch_cascade: int = Field(
        10_000,
        ge=100,
        le=1_000_000,
        description="[messages] most messages queued by handlers in one dispatch cascade",
    )


class LoggingConfig(Section):
    """Structured logs: JSON lines for journald, readable lines on a terminal."""

    level: Literal["debug", "info", "warning", "error"] = Field(
        "info", description="lowest level written"
    )
    format: Literal["auto", "json", "console"] = Field(
        "auto", **restart("auto: console on a terminal, JSON lines otherwise")
    )
    status_log_period_s: float = Field(
        60.0, ge=0, le=86_400, description="[s] how often status is logged; 0 never"
    )


class RobotConfig(Section):
    """The robot body: footprint and motion limits."""

    name: str = Field("navd-robot", min_length=1, max_length=64, description="robot name")
    footprint: Literal["circle", "rectangle"] = Field(
        "circle", description="footprint shape around base_link"
    )
    radius_m: float = Field(0.2, gt=0, le=5, description="[m] circle footprint radius")
    length_m: float = Field(0.4, gt=0, le=10, description="[m] rectangle footprint length (x)")
    width_m: float = Field(0.3, gt=0, le=10, description="[m] rectangle footprint width (y)")
    track_width_m: float = Field(
        0.3, gt=0, le=5, description="[m] distance between the left and right wheels"
    )
    max_linear_speed_mps: float = Field(0.5, gt=0, le=10, description="[m/s] top forward speed")
    max_reverse_speed_mps: float = Field(
        0.2, ge=0, le=10, description="[m/s] top backward speed (0 forbids reversing)"
    )
    max_angular_speed_radps: float = Field(1.5, gt=0, le=20, description="[rad/s] top yaw rate")
    max_linear_accel_mps2: float = Field(
        0.5, gt=0, le=20, description="[m/s^2] top linear acceleration"
    )
    max_angular_accel_radps2: float = Field(
        2.0, gt=0, le=50, description="[rad/s^2] top angular acceleration"
    )

    @model_validator(mode="after")
    def _reverse_within_forward(self) -> RobotConfig:
        if self.max_reverse_speed_mps > self.max_linear_speed_mps:
            raise ValueError(
                f"robot.max_reverse_speed_mps ({self.max_reverse_speed_mps}) must not exceed "
                f"robot.max_linear_speed_mps ({self.max_linear_speed_mps})"
            )
        return self


class LidarConfig(Section):
    """The 2D lidar: where it sits on the robot and its shortest trusted range."""

    x_m: float = Field(0.0, ge=-5, le=5, description="[m] lidar x in base_link (forward)")
    y_m: float = Field(0.0, ge=-5, le=5, description="[m] lidar y in base_link (left)")
    yaw_rad: float = Field(
        0.0,
        ge=-3.1416,
        le=3.1416,
        description="[rad] lidar yaw in base_link, counter-clockwise from the robot's forward",
    )
    min_range_m: float = Field(
        0.1,
        ge=0,
        le=10,
        description="[m] shorter ranges are ignored (the robot's own body, dust on the window)",
    )


class ChassisConfig(Section):
    """The STM32 on a UART that takes one "%d %d" line of wheel commands per period."""

    enabled: bool = Field(False, **restart("drive a real chassis on the serial port"))
    port: str = Field("/dev/ttyS0", min_length=1, **restart("serial device path"))
    baudrate: int = Field(115200, **restart("[baud] serial speed; a standard rate"))
    line_ending: Literal["lf", "crlf"] = Field("lf", description="line ending sent after a command")
    command_rate_hz: float = Field(
        20.0, ge=1, le=200, description="[Hz] how often a wheel command line is written"
    )
    scale_per_mps: float = Field(
        1000.0, gt=0, le=100_000, description="[units/(m/s)] wheel command per wheel speed"
    )
    deadband: int = Field(
        0, ge=0, le=100_000, description="[units] smaller wheel commands are sent as 0"
    )
    limit: int = Field(
        1000, gt=0, le=1_000_000, description="[units] wheel commands are clamped to +-limit"
    )
    invert_left: bool = Field(False, description="negate the left wheel command")
    invert_right: bool = Field(False, description="negate the right wheel command")
    reconnect_initial_s: float = Field(
        0.2, gt=0, le=60, description="[s] first wait before reopening a lost port"
    )
    reconnect_max_s: float = Field(
        5.0, gt=0, le=600, description="[s] longest wait between reopening attempts"
    )
    feedback: Literal["off", "log", "encoders"] = Field(
        "log",
        description='lines the STM32 sends back: ignore, log, or parse "%d %d" as measured '
        "wheel speeds in command units into wheel odometry",
    )

    @model_validator(mode="after")
    def _consistent(self) -> ChassisConfig:
        if self.baudrate not in STANDARD_BAUD_RATES:
            raise ValueError(
                f"chassis.baudrate {self.baudrate} is not a standard rate; "
                f"use one of {', '.join(map(str, STANDARD_BAUD_RATES))}"
            )
        if self.deadband >= self.limit:
            raise ValueError(
                f"chassis.deadband ({self.deadband}) must be below chassis.limit ({self.limit})"
            )
        if self.reconnect_initial_s > self.reconnect_max_s:
            raise ValueError(
                f"chassis.reconnect_initial_s ({self.reconnect_initial_s}) must not exceed "
                f"chassis.reconnect_max_s ({self.reconnect_max_s})"
            )
        return self


class TcpConfig(Section):
    """The TCP server that sensor and control clients connect to."""

    host: str = Field("127.0.0.1", min_length=1, **restart("address to listen on"))
    port: int = Field(7420, ge=0, le=65535, **restart("TCP port to listen on; 0 picks a free one"))
    token: str | None = Field(
        None,
        min_length=16,
        examples=["change-me-to-a-long-random-secret"],
        **restart("shared secret clients give in hello; required beyond loopback", secret=True),
    )
    allow_privileged_changes: bool = Field(
        False,
        **restart(
            "let control clients change privileged keys (safety, speed limits, footprint, "
            "chassis, lidar mount, paths, connection and module limits, keep-out zones, the "
            "localization loss thresholds); the config file and SIGHUP always may"
        ),
    )
    max_clients: int = Field(
        32,
        ge=1,
        le=1024,
        description="[clients] most clients connected at once (after their hello)",
    )
    max_pending: int = Field(
        16,
        ge=1,
        le=1024,
        description="[connections] most connections waiting to say hello; one more closes the "
        "oldest of them (they never count against tcp.max_clients)",
    )
    control_idle_timeout_s: float = Field(
        300.0,
        ge=1,
        le=86_400,
        description="[s] a control client that sends nothing for this long and has no status "
        "subscription is disconnected (a ping keeps it)",
    )
    sensor_idle_timeout_s: float = Field(
        60.0,
        ge=1,
        le=86_400,
        description="[s] a sensor that sends nothing, not even a ping, for this long is "
        "disconnected (it frees its slot; it stays stale, and holds the robot, until it "
        "sends data)",
    )
    slow_reader_timeout_s: float = Field(
        10.0,
        ge=0.5,
        le=3600,
        description="[s] a client that leaves its status frames unread for this long (every "
        "one dropped) is disconnected",
    )
    max_line_bytes: int = Field(
        262_144, ge=1024, le=16_777_216, description="[bytes] longest accepted line or frame"
    )
    handshake_timeout_s: float = Field(
        5.0, gt=0, le=60, description="[s] time a new client has to send hello"
    )
    read_coalesce_ms: float = Field(
        20.0,
        ge=0,
        le=50,
        description="[ms] after reading a fast sensor connection (several lines at once, or "
        "lines closer than this), wait this long before the next read, so it is handled many "
        "lines per wakeup; adds at most this latency, only to streams faster than 1/this; "
        "0 reads every line at once",
    )
    status_queue: int = Field(
        8, ge=1, le=1024, description="[messages] status messages buffered per slow subscriber"
    )
    lidar_timeout_s: float = Field(
        0.2,
        gt=0,
        le=60,
        description="[s] a lidar silent this long is stale and holds the robot; a sensor "
        "slower than its timeout is given its own period x 1.25 + 50 ms instead",
    )
    imu_timeout_s: float = Field(
        0.2, gt=0, le=60, description="[s] an IMU silent this long is stale and holds the robot"
    )
    gps_timeout_s: float = Field(
        1.3,
        gt=0,
        le=600,
        description="[s] a GPS silent this long is stale (it holds the robot only with no "
        "lidar); a receiver faster than 1 Hz is caught sooner with a lower value",
    )
    compass_timeout_s: float = Field(
        1.0, gt=0, le=600, description="[s] a compass silent this long is stale"
    )
    wheel_odometry_timeout_s: float = Field(
        0.2,
        gt=0,
        le=60,
        description="[s] wheel odometry silent this long is stale (it holds the robot only "
        "with no lidar)",
    )

    @model_validator(mode="after")
    def _token_beyond_loopback(self) -> TcpConfig:
        if self.token is None and not _is_loopback(self.host):
            raise ValueError(
                f"tcp.host {self.host!r} listens beyond loopback, so tcp.token must be set "
                f"(at least 16 characters) for clients to authenticate"
            )
        return self


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class SafetyConfig(Section):
    """When the robot must stop, whatever the planner says."""

    reaction_timeout_s: float = Field(
        0.5, gt=0, le=10, description="[s] stop when no fresh velocity command came for this long"
    )
    use_collisions: bool = Field(True, description="stop for obstacles (the seed's UseCollisions)")
    collision_distance_m: float = Field(
        0.1, ge=0, le=5, description="[m] margin around the footprint a trajectory must keep"
    )
    stop_distance_m: float = Field(
        0.15, ge=0, le=5, description="[m] scan points this close ahead of the footprint stop it"
    )
    slowdown_distance_m: float = Field(
        0.5, ge=0, le=10, description="[m] scan points this close ahead slow the robot down"
    )
    slowdown_factor: float = Field(
        0.4, gt=0, le=1, description="[ratio] speed scale inside the slow-down zone"
    )

    @model_validator(mode="after")
    def _zones_nested(self) -> SafetyConfig:
        if self.slowdown_distance_m < self.stop_distance_m:
            raise ValueError(
                f"safety.slowdown_distance_m ({self.slowdown_distance_m}) must be at least "
                f"safety.stop_distance_m ({self.stop_distance_m})"
            )
        return self


class SlamConfig(Section):
    """Scan matching and the occupancy grid (the seed's IcpSlamConfig and MatchingParams)."""

    updating_map: bool = Field(True, description="add scans to the map (off: localize only)")
    resolution_m: float = Field(0.05, ge=0.01, le=1, **restart("[m] occupancy grid cell size"))
    voxel_size_m: float = Field(
        0.1, ge=0.01, le=2, description="[m] voxel size for scan downsampling and ICP"
    )
    max_range_m: float = Field(
        12.0, gt=0, le=100, description="[m] longer ranges are not used for mapping and matching"
    )
    search_xy_m: float = Field(
        0.3, gt=0, le=5, description="[m] half-width of the correlative search window in x and y"
    )
    search_yaw_rad: float = Field(
        0.35, gt=0, le=3.1416, description="[rad] half-width of the correlative search in yaw"
    )
    blur_sigma_m: float = Field(
        0.05, gt=0, le=1, description="[m] Gaussian blur of the correlation grid"
    )
    min_match_score: float = Field(
        0.3,
        ge=0,
        le=1,
        description="[ratio] scans whose points on mapped ground match worse than this keep the "
        "odometry pose, unmapped (on mostly new ground they are mapped from it)",
    )
    prior_weight_per_m2: float = Field(
        0.5,
        ge=0,
        le=1000,
        description="[1/m^2] trust in the odometry: match score lost per squared metre a match "
        "lies from the odometry's prediction (raise it for good wheel odometry)",
    )
    prior_weight_per_rad2: float = Field(
        1.0,
        ge=0,
        le=10000,
        description="[1/rad^2] trust in the odometry's heading: match score lost per squared "
        "radian a match turns from the odometry's prediction",
    )
    loop_closure: bool = Field(
        False,
        **restart(
            "match keyframes onto old places and re-solve the pose graph (costs CPU: off "
            "unless the robot revisits places after drifting metres)"
        ),
    )
    loop_search_radius_m: float = Field(
        10.0, gt=0, le=100, description="[m] how far away an old keyframe may be to try a loop"
    )
    loop_search_xy_m: float = Field(
        4.0,
        gt=0,
        le=50,
        description="[m] largest half-width of the loop closure search window (it grows by 3 % "
        "of the path driven since the old pass, from 1 m)",
    )
    loop_min_score: float = Field(
        0.65, gt=0, le=1, description="[ratio] match score a loop closure must reach"
    )
    keyframe_distance_m: float = Field(
        0.3, gt=0, le=10, description="[m] travel that makes a new keyframe"
    )
    keyframe_angle_rad: float = Field(
        0.3, gt=0, le=3.1416, description="[rad] rotation that makes a new keyframe"
    )
    map_dir: str = Field("maps", min_length=1, description="folder where maps are saved")
    map_name: str = Field(
        "map",
        pattern=MAP_NAME_PATTERN,
        description="base name of saved map files: letters, digits, _ . - (no folders; they "
        "go in map_dir)",
    )
    load_map: str | None = Field(
        None,
        examples=["maps/office.yaml"],
        **restart("map .yaml to load at start-up and localize on; unset: start a new map"),
    )
    save_on_shutdown: bool = Field(False, description="save the map when the daemon stops")


class EstimationConfig(Section):
    """Madgwick IMU filter, UKF and the event/state queues."""

    madgwick_beta: float = Field(
        0.1, ge=0, le=10, description="[rad/s] Madgwick gain (gyro error the accel corrects)"
    )
    accel_reject_mps2: float = Field(
        2.0,
        gt=0,
        le=50,
        description="[m/s^2] skip the accelerometer correction while |accel| is off g by more",
    )
    gyro_bias_gain_per_s: float = Field(
        0.2, ge=0, le=10, description="[1/s] how fast gyro bias is learned while still (0: off)"
    )
    still_gyro_radps: float = Field(
        0.03, gt=0, le=1, description="[rad/s] gyro rate below which the IMU may be still"
    )
    still_time_s: float = Field(
        1.0, ge=0, le=60, description="[s] stillness needed before gyro bias is learned"
    )
    imu_max_gap_s: float = Field(
        0.1, gt=0, le=5, description="[s] longer gaps between IMU samples are integrated as this"
    )
    imu_window_s: float = Field(
        0.05,
        gt=0,
        le=1,
        description="[s] IMU samples averaged into each position event (yaw rate, acceleration)",
    )
    imu_yaw_rate_std_radps: float = Field(
        0.02, gt=0, le=10, description="[rad/s] noise of the averaged IMU yaw rate"
    )
    imu_accel_std_mps2: float = Field(
        0.3, gt=0, le=100, description="[m/s^2] noise of the averaged IMU acceleration"
    )
    nonholonomic_std_mps: float | None = Field(
        0.05,
        gt=0,
        le=10,
        description="[m/s] sideways velocity noise of a differential drive; unset: no constraint",
    )
    wheel_linear_std_mps: float = Field(
        0.05, gt=0, le=10, description="[m/s] noise of wheel odometry forward velocity"
    )
    wheel_angular_std_radps: float = Field(
        0.05, gt=0, le=10, description="[rad/s] noise of wheel odometry yaw rate"
    )
    ukf_alpha: float = Field(0.1, gt=0, le=1, description="[1] Merwe sigma point spread alpha")
    ukf_beta: float = Field(2.0, ge=0, le=10, description="[1] Merwe prior knowledge beta")
    ukf_kappa: float = Field(
        6.0, ge=-8.9, le=100, description="[1] Merwe kappa (the seed uses N-3 = 6)"
    )
    accel_noise_mps2: float = Field(
        0.5, gt=0, le=100, description="[m/s^2] process noise of the linear acceleration"
    )
    angular_accel_noise_radps2: float = Field(
        1.0, gt=0, le=100, description="[rad/s^2] process noise of the angular acceleration"
    )
    lidar_gate_chi2: float = Field(
        16.3, gt=0, le=1e6, description="[chi2] Mahalanobis gate of lidar poses (3 dof)"
    )
    gps_gate_chi2: float = Field(
        13.8, gt=0, le=1e6, description="[chi2] Mahalanobis gate of GPS positions (2 dof)"
    )
    compass_gate_chi2: float = Field(
        10.8, gt=0, le=1e6, description="[chi2] Mahalanobis gate of compass yaw (1 dof)"
    )
    wheel_gate_chi2: float = Field(
        13.8, gt=0, le=1e6, description="[chi2] Mahalanobis gate of wheel odometry (2 dof)"
    )
    history_horizon_s: float = Field(
        1.0, gt=0, le=30, description="[s] late measurements older than this are dropped"
    )
    max_events: int = Field(
        5000, ge=10, le=1_000_000, description="[events] most events kept for late corrections"
    )
    reset_inflation: float = Field(
        10.0, ge=1, le=1e6, description="[ratio] covariance scale after a numerical reset"
    )
    initial_velocity_std_mps: float = Field(
        0.5, gt=0, le=100, description="[m/s] velocity uncertainty when the filter starts"
    )
    datum_max_accuracy_m: float = Field(
        5.0, gt=0, le=1000, description="[m] worst fix accuracy accepted to set the GPS datum"
    )
    degraded_position_std_m: float = Field(
        0.3, gt=0, le=100, description="[m] position std above which localization is degraded"
    )
    lost_position_std_m: float = Field(
        1.0, gt=0, le=1000, description="[m] position std above which localization is lost"
    )
    publish_rate_hz: float = Field(
        20.0, gt=0, le=1000, **restart("[Hz] how often the fused pose is published")
    )
    imu_history_s: float = Field(
        2.0, gt=0, le=60, **restart("[s] IMU samples kept for late position events")
    )

    @model_validator(mode="after")
    def _degraded_before_lost(self) -> EstimationConfig:
        if self.degraded_position_std_m >= self.lost_position_std_m:
            raise ValueError(
                f"estimation.degraded_position_std_m ({self.degraded_position_std_m}) must be "
                f"below estimation.lost_position_std_m ({self.lost_position_std_m})"
            )
        if self.imu_history_s < self.history_horizon_s + self.imu_window_s:
            raise ValueError(
                f"estimation.imu_history_s ({self.imu_history_s}) must cover "
                f"estimation.history_horizon_s + estimation.imu_window_s "
                f"({self.history_horizon_s + self.imu_window_s}) so late events find IMU data"
            )
        return self


class WorldConfig(Section):
    """Geographic frame: GPS and compass into the map frame (the seed's WorldMapConfig)."""

    utm_zone: int | None = Field(
        None, ge=1, le=60, examples=[33], description="[zone] fixed UTM zone; unset: automatic"
    )
    utm_threshold_m: float = Field(
        10_000.0, gt=0, le=1e6, description="[m] fixes farther than this from the datum are refused"
    )
    map_rotation_rad: float = Field(
        0.0, ge=-3.1416, le=3.1416, description="[rad] map +x measured counter-clockwise from east"
    )
    coords_lifetime_s: float = Field(
        1.0, gt=0, le=60, description="[s] GPS fixes older than this are ignored"
    )
    datum_latitude_deg: float | None = Field(
        None, ge=-90, le=90, examples=[52.52], description="[deg] map origin latitude"
    )
    datum_longitude_deg: float | None = Field(
        None, ge=-180, le=180, examples=[13.405], description="[deg] map origin longitude"
    )
    magnetic_declination_deg: float = Field(
        0.0, ge=-180, le=180, description="[deg] true north minus magnetic north, east positive"
    )

    @model_validator(mode="after")
    def _datum_pair(self) -> WorldConfig:
        if (self.datum_latitude_deg is None) != (self.datum_longitude_deg is None):
            raise ValueError(
                "world.datum_latitude_deg and world.datum_longitude_deg must be set together "
                "(or both left unset to take the datum from the first good fix)"
            )
        if self.datum_latitude_deg is not None and not -80 <= self.datum_latitude_deg <= 84:
            raise ValueError(
                f"world.datum_latitude_deg ({self.datum_latitude_deg}) is outside UTM's "
                "latitude range [-80, 84], which the map frame is projected through"
            )
        return self


class PlanningConfig(Section):
    """Global A*, local DWA, velocity profile and stuck handling."""

    control_rate_hz: float = Field(20.0, ge=1, le=100, description="[Hz] local planner rate")
    prediction_horizon_s: float = Field(
        2.0, gt=0, le=10, description="[s] how far ahead DWA rolls trajectories out"
    )
    linear_samples: int = Field(
        20, ge=2, le=200, description="[count] linear velocities sampled in the window"
    )
    angular_samples: int = Field(
        21, ge=3, le=401, description="[count] angular velocities sampled in the window"
    )
    goal_weight: float = Field(1.0, ge=0, le=100, description="[1] weight of goal proximity")
    path_weight: float = Field(1.0, ge=0, le=100, description="[1] weight of closeness to path")
    clearance_weight: float = Field(
        0.5, ge=0, le=100, description="[1] weight of obstacle clearance"
    )
    oscillation_weight: float = Field(
        0.2, ge=0, le=100, description="[1] weight of the oscillation penalty"
    )
    heading_weight: float = Field(
        0.5, ge=0, le=100, description="[1] weight of target-heading alignment near the goal"
    )
    goal_xy_tolerance_m: float = Field(
        0.15, gt=0, le=10, description="[m] goal reached within this distance"
    )
    goal_yaw_tolerance_rad: float = Field(
        0.2, gt=0, le=3.1416, description="[rad] goal heading reached within this angle"
    )
    inflation_radius_m: float = Field(
        0.5, ge=0, le=10, description="[m] costs decay to zero this far from obstacles"
    )
    cost_decay: float = Field(
        3.0, gt=0, le=100, description="[1/m] exponential decay rate of the inflation cost"
    )
    replan_period_s: float = Field(
        5.0, ge=0, le=600, description="[s] replan on this timer; 0 replans only on events"
    )
    max_path_deviation_m: float = Field(
        0.5, gt=0, le=10, description="[m] straying farther from the path triggers a replan"
    )
    approach_distance_m: float = Field(
        1.0, ge=0, le=20, description="[m] start slowing down this far from the goal"
    )
    angular_limit_table: Table = Field(
        ((0.0, 1.5), (0.5, 0.8)),
        description="[(m/s, rad/s)] top yaw rate as a function of speed, linearly interpolated",
    )
    stuck_time_s: float = Field(
        3.0, gt=0, le=600, description="[s] this long without progress means stuck"
    )
    stuck_min_progress_m: float = Field(
        0.1, gt=0, le=10, description="[m] progress that resets the stuck timer"
    )
    stuck_time_force_backward_s: float = Field(
        5.0, gt=0, le=600, description="[s] stuck this long forces backward motion"
    )
    max_stuck_time_s: float = Field(
        15.0, gt=0, le=3600, description="[s] stuck this long reports StuckDetected and replans"
    )
    keep_out_zones: Polygons = Field(
        (),
        description="[m] polygons in the map frame the robot must never enter",
    )
    min_linear_speed_mps: float = Field(
        0.05, ge=0, le=10, description="[m/s] slowest forward speed the velocity profile asks for"
    )
    acceleration_time_s: float = Field(
        1.0, ge=0, le=60, description="[s] the start ramp reaches top speed after this long"
    )
    lookahead_m: float = Field(
        1.0, gt=0, le=20, description="[m] DWA aims at the path point this far ahead"
    )
    sim_step_s: float = Field(0.1, ge=0.01, le=1, description="[s] time step of the DWA rollouts")
    occupied_threshold_pct: int = Field(
        65, ge=1, le=100, description="[%] map cells at or above this occupancy are obstacles"
    )
    allow_unknown: bool = Field(True, description="routes may cross unknown (unmapped) cells")
    unknown_cost: float = Field(
        0.5, ge=0, le=1, description="[1] cost of an unknown cell, on the inflation scale 0..1"
    )
    cost_weight: float = Field(
        3.0,
        ge=0,
        le=100,
        description="[1] a step through a cell of cost c counts (1 + cost_weight * c) times its "
        "length, so routes keep away from walls",
    )
    obstacle_persistence_s: float = Field(
        2.0, ge=0, le=600, description="[s] a scan obstacle not seen again is forgotten after this"
    )
    obstacle_range_m: float = Field(
        12.0,
        gt=0,
        le=100,
        description="[m] lidar ranges farther than this neither mark nor clear scan obstacles",
    )
    smooth_path: bool = Field(True, description="shortcut the A* path where the line is clear")
    stuck_rotation_tolerance_rad: float = Field(
        0.5, gt=0, le=6.3, description="[rad] turning this far also counts as progress"
    )
    backup_distance_m: float = Field(
        0.5, gt=0, le=10, description="[m] a forced backward move goes this far before replanning"
    )
    max_stuck_replans: int = Field(
        3, ge=0, le=100, description="[count] replans after StuckDetected before the goal fails"
    )
    max_goal_distance_m: float = Field(
        100.0,
        gt=0,
        le=10_000,
        description="[m] a goal farther than this from the robot fails at once with the reason "
        "(give waypoints in between); bounds the area A* searches",
    )
    max_plan_cells: int = Field(
        9_000_000,
        ge=10_000,
        le=400_000_000,
        description="[cells] the grid A* plans on (the map, the robot and the goal with "
        "margins) may hold at most this many cells, about 45 bytes each at its peak; a goal "
        "needing more fails with the reason",
    )

    @model_validator(mode="after")
    def _consistent(self) -> PlanningConfig:
        weights = (
            self.goal_weight,
            self.path_weight,
            self.clearance_weight,
            self.oscillation_weight,
            self.heading_weight,
        )
        if not any(w > 0 for w in weights):
            raise ValueError("planning: at least one of the *_weight metrics must be > 0")
        if not self.stuck_time_s < self.stuck_time_force_backward_s < self.max_stuck_time_s:
            raise ValueError(
                "planning: need stuck_time_s < stuck_time_force_backward_s < max_stuck_time_s, "
                f"got {self.stuck_time_s} < {self.stuck_time_force_backward_s} < "
                f"{self.max_stuck_time_s}"
            )
        _check_table(self.angular_limit_table)
        if self.lookahead_m < self.goal_xy_tolerance_m:
            raise ValueError(
                f"planning.lookahead_m ({self.lookahead_m}) must be at least "
                f"planning.goal_xy_tolerance_m ({self.goal_xy_tolerance_m})"
            )
        if self.sim_step_s > self.prediction_horizon_s:
            raise ValueError(
                f"planning.sim_step_s ({self.sim_step_s}) is longer than "
                f"planning.prediction_horizon_s ({self.prediction_horizon_s})"
            )
        for i, zone in enumerate(self.keep_out_zones):
            if len(zone) < 3:
                raise ValueError(
                    f"planning.keep_out_zones[{i}] has {len(zone)} points; a polygon needs >= 3"
                )
        return self


def _check_table(table: tuple[Point2, ...]) -> None:
    if len(table) < 1:
        raise ValueError("planning.angular_limit_table needs at least one [speed, yaw_rate] row")
    speeds = [row[0] for row in table]
    if speeds[0] < 0 or any(b <= a for a, b in itertools.pairwise(speeds)):
        raise ValueError(
            f"planning.angular_limit_table speeds must start >= 0 and strictly increase, "
            f"got {speeds}"
        )
    if any(row[1] <= 0 for row in table):
        raise ValueError("planning.angular_limit_table yaw rates must all be > 0")


class NavdConfig(BaseModel):
    """The whole configuration, one section per subsystem."""

    model_config = ConfigDict(
        strict=True, extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False
    )

    robot: RobotConfig = Field(default_factory=RobotConfig)
    lidar: LidarConfig = Field(default_factory=LidarConfig)
    chassis: ChassisConfig = Field(default_factory=ChassisConfig)
    tcp: TcpConfig = Field(default_factory=TcpConfig)
    safety: SafetyConfig = Field(default_factory=SafetyConfig)
    slam: SlamConfig = Field(default_factory=SlamConfig)
    estimation: EstimationConfig = Field(default_factory=EstimationConfig)
    world: WorldConfig = Field(default_factory=WorldConfig)
    planning: PlanningConfig = Field(default_factory=PlanningConfig)
    lifecycle: LifecycleConfig = Field(default_factory=LifecycleConfig)
    logging: LoggingConfig = Field(default_factory=LoggingConfig)

    @model_validator(mode="after")
    def _across_sections(self) -> NavdConfig:
        for reach, key in (
            (self.slam.max_range_m, "slam.max_range_m"),
            (self.planning.obstacle_range_m, "planning.obstacle_range_m"),
        ):
            if self.lidar.min_range_m >= reach:
                raise ValueError(
                    f"lidar.min_range_m ({self.lidar.min_range_m}) must be below {key} ({reach})"
                )
        top_yaw = max(row[1] for row in self.planning.angular_limit_table)
        if top_yaw > self.robot.max_angular_speed_radps:
            raise ValueError(
                f"planning.angular_limit_table allows {top_yaw} rad/s, above "
                f"robot.max_angular_speed_radps ({self.robot.max_angular_speed_radps})"
            )
        if self.planning.min_linear_speed_mps > self.robot.max_linear_speed_mps:
            raise ValueError(
                f"planning.min_linear_speed_mps ({self.planning.min_linear_speed_mps}) is above "
                f"robot.max_linear_speed_mps ({self.robot.max_linear_speed_mps})"
            )
        two_periods_s = 2.0 / self.planning.control_rate_hz
        if self.safety.reaction_timeout_s < two_periods_s:
            raise ValueError(
                f"safety.reaction_timeout_s ({self.safety.reaction_timeout_s}) is shorter than two "
                f"planner periods ({two_periods_s:.3g} s at planning.control_rate_hz = "
                f"{self.planning.control_rate_hz}): the robot would stop between commands"
            )
        chassis_period_s = 1.0 / self.chassis.command_rate_hz
        if chassis_period_s > self.safety.reaction_timeout_s / 2.0:
            raise ValueError(
                f"chassis.command_rate_hz ({self.chassis.command_rate_hz}) is too slow for "
                f"safety.reaction_timeout_s ({self.safety.reaction_timeout_s}): a command would be "
                f"stale before it is written; need a period of at most half the timeout"
            )
        return self
