from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navd.lifecycle.errors import MessageError
from navd.lifecycle.messages import (
    CompassHeading,
    ConfigChange,
    GpsFix,
    LaserScan,
    PoseEstimate,
    VelocityCommand,
    describe,
)


def _scan(**overrides: object) -> LaserScan:
    fields: dict[str, object] = dict(
        stamp=1.0,
        received=1.01,
        device_id="lidar0",
        angle_min=-math.pi / 2,
        angle_increment=math.pi / 2,
        ranges=[1.0, 2.0, 3.0],
        range_min=0.1,
        range_max=10.0,
    )
    fields.update(overrides)
    return LaserScan(**fields)  # type: ignore[arg-type]


def test_scan_ranges_are_a_read_only_copy() -> None:
    source = np.array([1.0, 2.0, 3.0])
    scan = _scan(ranges=source)
    source[0] = 99.0
    assert scan.ranges[0] == 1.0
    assert scan.ranges.dtype == np.float32
    with pytest.raises(ValueError, match="read-only"):
        scan.ranges[0] = 5.0


def test_scan_angles_follow_laser_scan_meaning() -> None:
    np.testing.assert_allclose(_scan().angles, [-math.pi / 2, 0.0, math.pi / 2])


def test_messages_are_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        _scan().range_max = 5.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"range_min": 5.0, "range_max": 1.0}, "need 0 <= range_min < range_max"),
        ({"range_min": -0.1}, "need 0 <= range_min < range_max"),
        ({"angle_increment": 0.0}, "angle_increment must be non-zero"),
        ({"ranges": [[1.0, 2.0]]}, r"ranges must be a 1-D array, got shape \(1, 2\)"),
        ({"stamp": math.nan}, "stamp must be a finite number"),
        ({"time_increment": -1e-3}, "time_increment must be >= 0"),
    ],
)
def test_scan_rejects_impossible_values(overrides: dict[str, object], match: str) -> None:
    with pytest.raises(MessageError, match=match):
        _scan(**overrides)


@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (
            lambda: GpsFix(
                stamp=0,
                received=0,
                device_id="g",
                latitude_deg=91.0,
                longitude_deg=0.0,
                altitude_m=0.0,
                horizontal_accuracy_m=1.0,
            ),
            "latitude_deg must be in",
        ),
        (
            lambda: GpsFix(
                stamp=0,
                received=0,
                device_id="g",
                latitude_deg=0.0,
                longitude_deg=-181.0,
                altitude_m=0.0,
                horizontal_accuracy_m=1.0,
            ),
            "longitude_deg must be in",
        ),
        (
            lambda: GpsFix(
                stamp=0,
                received=0,
                device_id="g",
                latitude_deg=0.0,
                longitude_deg=0.0,
                altitude_m=0.0,
                horizontal_accuracy_m=0.0,
            ),
            "horizontal_accuracy_m must be > 0",
        ),
        (
            lambda: CompassHeading(
                stamp=0, received=0, device_id="c", bearing_deg=360.0, accuracy_deg=2.0
            ),
            r"bearing_deg must be in \[0, 360\)",
        ),
        (
            lambda: VelocityCommand(
                stamp=0, received=0, linear_mps=math.inf, angular_radps=0.0, source="x"
            ),
            "linear_mps must be a finite number",
        ),
        (
            lambda: PoseEstimate(
                stamp=0, received=0, x_m=0, y_m=0, yaw_rad=0, covariance=np.eye(2)
            ),
            r"covariance must be 3x3",
        ),
    ],
)
def test_messages_reject_impossible_values(factory: object, match: str) -> None:
    with pytest.raises(MessageError, match=match):
        factory()  # type: ignore[operator]


def test_config_change_mapping_is_immutable() -> None:
    changes = {"safety.reaction_timeout_s": 0.3}
    msg = ConfigChange(stamp=0, received=0, request_id="r1", changes=changes)
    changes["safety.reaction_timeout_s"] = 9.0
    assert msg.changes["safety.reaction_timeout_s"] == 0.3
    with pytest.raises(TypeError):
        msg.changes["x"] = 1  # type: ignore[index]


def test_describe_summarises_arrays_by_shape() -> None:
    summary = describe(_scan(ranges=np.ones(1440)))
    assert summary["type"] == "LaserScan"
    assert summary["ranges"] == "array(1440,)"
    assert summary["device_id"] == "lidar0"
    assert summary["stamp"] == 1.0
