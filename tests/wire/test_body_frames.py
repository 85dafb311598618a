"""The range, contact, points and battery frames: read from lines, and what is wrong with a
bad one named."""

from __future__ import annotations

import base64
import math

import numpy as np
import pytest

from navd.wire import (
    BatteryFrame,
    ContactFrame,
    PointsFrame,
    RangeFrame,
    WireError,
    decode_sensor,
)


def test_each_body_frame_reads_from_its_roles_line() -> None:
    sonar = decode_sensor(
        "range",
        b'{"type":"range","stamp":1.0,"sensor":"front","range":0.42,"field_of_view":0.5,'
        b'"max_range":4.0}',
    )
    assert isinstance(sonar, RangeFrame) and sonar.range == 0.42 and sonar.sensor == "front"
    clear = decode_sensor(
        "range", b'{"type":"range","stamp":1.0,"range":null,"field_of_view":0.5,"max_range":4}'
    )
    assert isinstance(clear, RangeFrame) and clear.range is None
    bump = decode_sensor(
        "contact",
        b'{"type":"contact","stamp":1.0,"sensor":"left","kind":"bumper","triggered":true}',
    )
    assert isinstance(bump, ContactFrame) and bump.triggered
    battery = decode_sensor(
        "battery", b'{"type":"battery","stamp":1.0,"voltage":12.1,"current":-1.5,"percentage":0.8}'
    )
    assert isinstance(battery, BatteryFrame) and battery.percentage == 0.8


@pytest.mark.parametrize(
    ("line", "field"),
    [
        (
            b'{"type":"range","stamp":1,"range":1,"field_of_view":0.5,"max_range":4,"min_range":5}',
            "max_range",
        ),
        (b'{"type":"range","stamp":1,"range":NaN,"field_of_view":0.5,"max_range":4}', "range"),
        (b'{"type":"range","stamp":1,"range":1,"field_of_view":4,"max_range":4}', "field_of_view"),
        (b'{"type":"contact","stamp":1,"kind":"bump","triggered":true}', "kind"),
        (b'{"type":"battery","stamp":1,"voltage":12,"percentage":80}', "percentage"),
        (b'{"type":"points","stamp":1,"points_f32":"!!"}', "points_f32"),
    ],
)
def test_a_bad_body_frame_names_its_field(line: bytes, field: str) -> None:
    role = line.split(b'"type":"')[1].split(b'"')[0].decode()
    with pytest.raises(WireError, match=field):
        frame = decode_sensor(role, line)
        assert isinstance(frame, PointsFrame)
        frame.points_array()


def test_points_come_in_the_cameras_body_axes() -> None:
    optical = np.array([[0.1, -0.2, 2.0], [np.nan, 0.0, 1.0]], dtype="<f4")  # x right, y down
    frame = PointsFrame(stamp=1.0, points_f32=base64.b64encode(optical.tobytes()).decode())
    (point,) = frame.points_array()  # the NaN point dropped
    np.testing.assert_allclose(point, [2.0, -0.1, 0.2], atol=1e-6)  # forward, left, up
    body = PointsFrame(
        stamp=1.0, frame="body", points_f32=base64.b64encode(optical[:1].tobytes()).decode()
    )
    np.testing.assert_allclose(body.points_array()[0], [0.1, -0.2, 2.0], atol=1e-6)
    with pytest.raises(WireError, match="whole number of xyz"):
        PointsFrame(stamp=1.0, points_f32=base64.b64encode(b"12345678").decode()).points_array()
    assert math.isfinite(point[0])
