"""How the daemon runs and talks: the event loop and supervision, the log, the TCP server."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from navd.config.fields import Section, is_loopback, restart

__all__ = ["LifecycleConfig", "LoggingConfig", "TcpConfig"]


MIN_SLICE_MS = 0.1  # the shortest time slice Linux gives a task that asks for one


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
    switch_interval_ms: float = Field(
        1.0,
        ge=0.1,
        le=100,
        **restart(
            "[ms] longest a thread running Python keeps the interpreter while another waits "
            "for it (Python's switch interval, 5 ms by its default): a worker's job then holds "
            "the event loop up for at most about this long"
        ),
    )
    loop_slice_ms: float = Field(
        0.3,
        ge=0.0,
        le=100,
        **restart(
            "[ms] time slice the event-loop thread asks the kernel for (Linux 6.12 and later): "
            "shorter than the default, it is run sooner when a message arrives while another "
            "program uses the CPU; 0 keeps the kernel's default"
        ),
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

    @model_validator(mode="after")
    def _slice_the_kernel_can_give(self) -> LifecycleConfig:
        if 0.0 < self.loop_slice_ms < MIN_SLICE_MS:
            raise ValueError(
                f"lifecycle.loop_slice_ms = {self.loop_slice_ms} is shorter than the kernel's "
                f"shortest slice ({MIN_SLICE_MS} ms): give at least that, or 0 for the "
                "kernel's default"
            )
        return self


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
    max_control_clients: int = Field(
        16,
        ge=1,
        le=1024,
        description="[clients] most control clients connected at once: the rest of "
        "tcp.max_clients is kept for sensors, so operator tools can never take the slot a "
        "restarting lidar or IMU needs",
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
    beacon_timeout_s: float = Field(
        5.0,
        gt=0,
        le=600,
        description="[s] a beacon sensor silent this long is stale (one that only speaks when "
        "it sees a beacon, a tag detector, needs room here)",
    )
    wheel_odometry_timeout_s: float = Field(
        0.2,
        gt=0,
        le=60,
        description="[s] wheel odometry silent this long is stale (it holds the robot only "
        "with no lidar)",
    )
    range_timeout_s: float = Field(
        0.5,
        gt=0,
        le=60,
        description="[s] a range sensor silent this long is stale: its obstacles are dropped "
        "(it does not hold the robot)",
    )
    contact_timeout_s: float = Field(
        0.5,
        gt=0,
        le=60,
        description="[s] a bumper or cliff sensor silent this long is stale and holds the "
        "robot (send the state at least this often)",
    )
    points_timeout_s: float = Field(
        1.0,
        gt=0,
        le=60,
        description="[s] a depth camera silent this long is stale: its obstacles are dropped",
    )
    battery_timeout_s: float = Field(
        10.0, gt=0, le=3600, description="[s] a battery sensor silent this long is stale"
    )

    @model_validator(mode="after")
    def _sensor_slots(self) -> TcpConfig:
        if self.max_control_clients >= self.max_clients:
            raise ValueError(
                f"tcp.max_control_clients ({self.max_control_clients}) must be below "
                f"tcp.max_clients ({self.max_clients}): the difference is kept for sensors"
            )
        return self

    @model_validator(mode="after")
    def _token_beyond_loopback(self) -> TcpConfig:
        if self.token is None and not is_loopback(self.host):
            raise ValueError(
                f"tcp.host {self.host!r} listens beyond loopback, so tcp.token must be set "
                f"(at least 16 characters) for clients to authenticate"
            )
        return self
