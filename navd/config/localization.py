"""Where the robot is: SLAM, the state estimator, and the world frame (GPS datum, UTM)."""

from __future__ import annotations

from pydantic import Field, model_validator

from navd.config.fields import MAP_NAME_PATTERN, Section, restart

__all__ = ["EstimationConfig", "SlamConfig", "WorldConfig"]


class SlamConfig(Section):
    """Scan matching and the occupancy grid (the seed's IcpSlamConfig and MatchingParams)."""

    enabled: bool = Field(
        True,
        **restart(
            "map and localize with the lidar; off (outdoors, on GPS, or with beacons): the lidar "
            "only shows obstacles, and the robot is placed by GPS, IMU, compass, wheels and "
            "beacons"
        ),
    )
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
    plausible_speed_mps: float = Field(
        2.5,
        gt=0,
        le=50,
        description="[m/s] the fastest the robot really moves between two scans (any robot a "
        "log is replayed for, too): a faster odometry step is a spike, not followed unless the "
        "scan fits clearly better there, and a match implying twice that speed is refused (a "
        "step is taken as lasting at least the scan period and 0.2 s: logs stamp scans in "
        "bursts)",
    )
    plausible_turn_radps: float = Field(
        3.0,
        gt=0,
        le=100,
        description="[rad/s] the fastest the robot really turns between two scans: as "
        "plausible_speed_mps, for turning",
    )
    lost_after_scans: int = Field(
        10,
        ge=0,
        le=1000,
        description="scans in a row on mapped ground that do not fit it (or fit far worse than "
        "the last ones) after which the robot is lost: it is stopped and the map searched for "
        "it, near its last good pose first (0: never)",
    )
    prior_weight_per_m2: float = Field(
        0.5,
        ge=0,
        le=1000,
        description="[1/m^2] trust in the odometry: match score lost per squared metre a match "
        "lies from the odometry's prediction (raise it for good wheel odometry)",
    )
    prior_axis_weight_per_m2: float = Field(
        40.0,
        ge=0,
        le=1000,
        description="[1/m^2] more trust in the odometry along the direction a scan's walls hold "
        "least (a corridor's length, where matches are drawn back toward where the map was drawn "
        "from): added to prior_weight_per_m2 along it, in full where the walls hold nothing "
        "along it, tapering to nothing where they hold half as much as across it (0: off)",
    )
    prior_weight_per_rad2: float | None = Field(
        None,
        ge=0,
        le=10000,
        description="[1/rad^2] trust in the odometry's heading: match score lost per squared "
        "radian a match turns from the odometry's prediction (unset: learned from how far the "
        "matched scans turned from it, 5-200)",
        examples=[50.0],
    )
    loop_closure: bool = Field(
        True,
        **restart(
            "match keyframes onto old places and re-solve the pose graph, so a robot back "
            "where it was after drifting metres closes the loop (off: the map keeps the drift; "
            "keyframes then keep no scans, and memory stays smaller)"
        ),
    )
    loop_search_radius_m: float = Field(
        15.0, gt=0, le=100, description="[m] how far away an old keyframe may be to try a loop"
    )
    loop_search_xy_m: float = Field(
        20.0,
        gt=0,
        le=50,
        description="[m] largest half-width of the loop closure search window (it grows by 6 % "
        "of the shortest path through the pose graph to the old pass, from 2 m)",
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
    autosave_period_s: float = Field(
        10.0,
        ge=0,
        le=3600,
        **restart(
            "[s] while the map grows it is saved this often as map_dir/autosave, so a crash or "
            "a power cut loses at most this much; the next start goes on from it (and finds "
            "the robot on it). A clean stop removes it. 0: never"
        ),
    )


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
