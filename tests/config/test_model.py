"""One test per validation rule of the config model: bounds, types, keys, cross-field rules."""

from __future__ import annotations

import pytest

from navd.config import ConfigError, NavdConfig, parse_config


def _problems(data: dict[str, object]) -> str:
    with pytest.raises(ConfigError) as info:
        parse_config(data)
    return str(info.value)


def test_defaults_are_valid() -> None:
    config = NavdConfig()
    assert config.tcp.host == "127.0.0.1" and config.tcp.token is None
    assert config.chassis.enabled is False


@pytest.mark.parametrize(
    ("data", "match"),
    [
        # unknown keys, with a suggestion
        (
            {"robot": {"max_speed_mps": 1.0}},
            r"robot\.max_speed_mps: unknown key \(did you mean 'max_linear_speed_mps'\?\)",
        ),
        ({"safty": {}}, r"safty: unknown key \(did you mean 'safety'\?\)"),
        # wrong types: strict, never coerced
        (
            {"robot": {"radius_m": "0.3"}},
            r"robot\.radius_m = '0\.3': Input should be a valid number",
        ),
        ({"tcp": {"port": 8000.0}}, r"tcp\.port = 8000\.0: Input should be a valid integer"),
        (
            {"slam": {"updating_map": "yes"}},
            r"slam\.updating_map = 'yes': Input should be a valid bool",
        ),
        ({"robot": {"footprint": "triangle"}}, r"robot\.footprint = 'triangle': Input should be"),
        ({"robot": []}, r"robot: must be a table \(\[robot\] section\), got \[\]"),
        # bounds, with the unit in the message
        (
            {"robot": {"max_linear_speed_mps": -0.5}},
            r"robot\.max_linear_speed_mps = -0\.5: Input should be greater than 0 "
            r"\(expected \[m/s\] top forward speed\)",
        ),
        (
            {"tcp": {"port": 70000}},
            r"tcp\.port = 70000: Input should be less than or equal to 65535",
        ),
        # a secret is never echoed, even a wrong one
        ({"tcp": {"token": "short"}}, r"tcp\.token = <redacted>: String should have at least 16"),
        ({"world": {"utm_zone": 61}}, r"world\.utm_zone = 61: Input should be less than or equal"),
        ({"lifecycle": {"worker_threads": 0}}, r"lifecycle\.worker_threads = 0"),
        (
            {"planning": {"angular_limit_table": [[0.0, 1.0, 2.0]]}},
            r"planning\.angular_limit_table\.0 = \(0\.0, 1\.0, 2\.0\)",
        ),
    ],
)
def test_field_rules_name_the_key(data: dict[str, object], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        parse_config(data)


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (
            {"robot": {"max_linear_speed_mps": 0.3, "max_reverse_speed_mps": 0.4}},
            r"robot\.max_reverse_speed_mps \(0\.4\) must not exceed robot\.max_linear_speed_mps",
        ),
        ({"chassis": {"baudrate": 12345}}, r"chassis\.baudrate 12345 is not a standard rate"),
        (
            {"chassis": {"deadband": 50, "limit": 50}},
            r"chassis\.deadband \(50\) must be below chassis\.limit \(50\)",
        ),
        (
            {"chassis": {"reconnect_initial_s": 10.0, "reconnect_max_s": 1.0}},
            r"chassis\.reconnect_initial_s \(10\.0\) must not exceed chassis\.reconnect_max_s",
        ),
        (
            {"tcp": {"host": "0.0.0.0"}},
            r"tcp\.host '0\.0\.0\.0' listens beyond loopback, so "
            r"tcp\.token must be set",
        ),
        (
            {"safety": {"stop_distance_m": 0.6, "slowdown_distance_m": 0.5}},
            r"safety\.slowdown_distance_m \(0\.5\) must be at least safety\.stop_distance_m",
        ),
        (
            {"lidar": {"min_range_m": 5.0}, "slam": {"max_range_m": 4.0}},
            r"lidar\.min_range_m \(5\.0\) must be below slam\.max_range_m \(4\.0\)",
        ),
        (
            {"lidar": {"min_range_m": 5.0}, "planning": {"obstacle_range_m": 4.0}},
            r"lidar\.min_range_m \(5\.0\) must be below planning\.obstacle_range_m",
        ),
        (
            {"world": {"datum_latitude_deg": 85.0, "datum_longitude_deg": 10.0}},
            r"world\.datum_latitude_deg \(85\.0\) is outside UTM's latitude range",
        ),
        (
            {"estimation": {"degraded_position_std_m": 2.0, "lost_position_std_m": 1.0}},
            r"estimation\.degraded_position_std_m \(2\.0\) must be below",
        ),
        (
            {"world": {"datum_latitude_deg": 52.0}},
            r"world\.datum_latitude_deg and world\.datum_longitude_deg must be set together",
        ),
        (
            {
                "planning": {
                    "goal_weight": 0.0,
                    "path_weight": 0.0,
                    "clearance_weight": 0.0,
                    "oscillation_weight": 0.0,
                    "heading_weight": 0.0,
                }
            },
            r"at least one of the \*_weight metrics must be > 0",
        ),
        (
            {"planning": {"stuck_time_s": 6.0}},
            r"need stuck_time_s < stuck_time_force_backward_s < max_stuck_time_s",
        ),
        (
            {"planning": {"angular_limit_table": [[0.5, 1.0], [0.2, 1.0]]}},
            r"speeds must start >= 0 and strictly increase",
        ),
        ({"planning": {"angular_limit_table": []}}, r"needs at least one \[speed, yaw_rate\] row"),
        ({"planning": {"angular_limit_table": [[0.0, 0.0]]}}, r"yaw rates must all be > 0"),
        (
            {"planning": {"keep_out_zones": [[[0, 0], [1, 0]]]}},
            r"planning\.keep_out_zones\[0\] has 2 points; a polygon needs >= 3",
        ),
        (
            {"planning": {"angular_limit_table": [[0.0, 3.0]]}},
            r"angular_limit_table allows 3\.0 rad/s, above robot\.max_angular_speed_radps \(1\.5\)",
        ),
        (
            {"chassis": {"command_rate_hz": 2.0}},
            r"chassis\.command_rate_hz \(2\.0\) is too slow for safety\.reaction_timeout_s",
        ),
        (
            {"safety": {"reaction_timeout_s": 0.05}},
            r"safety\.reaction_timeout_s \(0\.05\) is shorter than two planner periods",
        ),
    ],
)
def test_cross_field_rules(data: dict[str, object], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        parse_config(data)


def test_every_bad_key_is_reported_at_once() -> None:
    text = _problems(
        {
            "robot": {"max_speed_mps": 1.0, "radius_m": -1.0},
            "tcp": {"port": "80"},
        }
    )
    assert "3 problems" in text
    for key in ("robot.max_speed_mps", "robot.radius_m", "tcp.port"):
        assert key in text


def test_token_allows_listening_beyond_loopback() -> None:
    config = parse_config({"tcp": {"host": "0.0.0.0", "token": "a-long-enough-secret"}})
    assert config.tcp.host == "0.0.0.0"


@pytest.mark.parametrize("host", ["127.0.0.1", "127.5.5.5", "::1", "localhost"])
def test_loopback_hosts_need_no_token(host: str) -> None:
    assert parse_config({"tcp": {"host": host}}).tcp.host == host


def test_integers_are_accepted_where_floats_belong() -> None:
    assert parse_config({"robot": {"max_linear_speed_mps": 1}}).robot.max_linear_speed_mps == 1.0


def test_config_is_frozen() -> None:
    config = NavdConfig()
    with pytest.raises(ValueError, match="frozen"):
        config.safety.reaction_timeout_s = 1.0  # type: ignore[misc]
