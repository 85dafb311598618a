"""The emulated RPLIDAR read by two independent host drivers: rplidar (info, health, the
standard and the express scan) and pyrplidar (the scan modes GET_LIDAR_CONF describes, and
the dense capsules of an S1)."""

from __future__ import annotations

import contextlib
import io
import itertools

import pytest
from pyrplidar import PyRPlidar
from rplidar import RPLidar

from navd.sim.devices import MODELS, RplidarDevice
from tests.sim.devices.conftest import streaming

pytestmark = pytest.mark.usefixtures("no_modem_lines")

# Dense capsules: pyrplidar reads their distances big-endian, where Slamtec's SDK and every
# other field of the protocol are little-endian. Ranges whose two bytes are equal (0x0404 =
# 1028 mm, 0x0B0B = 2827 mm) read the same either way, so its reading checks the capsules'
# framing, checksums and angles, not the byte order.
NEAR_M, FAR_M = 1.028, 2.827


def room(angle_cw_deg: float) -> tuple[float, int]:
    """A wall on the lidar's right (80-100 deg clockwise), farther elsewhere."""
    return (NEAR_M, 47) if 80.0 <= angle_cw_deg <= 100.0 else (FAR_M, 30)


def _expected_mm(angle_deg: float) -> float | None:
    """The room's range at ``angle_deg``, None within a degree of the wall's edges."""
    if min(abs(angle_deg - 80.0), abs(angle_deg - 100.0)) < 1.0:
        return None
    return round(room(angle_deg)[0] * 1000)


@pytest.mark.parametrize("scan_type", ["normal", "express"])
def test_rplidar_reads_an_a1s_info_health_and_scans(scan_type: str) -> None:
    device = RplidarDevice(room, model="A1")
    with streaming(device.serve) as line:
        lidar = RPLidar(str(line.path), baudrate=115200, timeout=3)
        info = lidar.get_info()
        assert info["model"] == 0x18 and info["firmware"] == (1, 29)
        assert lidar.get_health() == ("Good", 0)
        measures = list(itertools.islice(lidar.iter_measures(scan_type=scan_type), 1500))
        lidar.stop()
        lidar.disconnect()
    checked = 0
    for _, _, angle, distance in measures[64:]:
        expected = _expected_mm(angle)
        if expected is not None and distance:
            assert distance == pytest.approx(expected, abs=1.0)
            checked += 1
    assert checked > 1000
    assert device.deaf_requests == []


def test_pyrplidar_reads_the_scan_modes_and_an_s1s_dense_capsules() -> None:
    device = RplidarDevice(room, model="S1")
    with streaming(device.serve) as line, contextlib.redirect_stdout(io.StringIO()):
        lidar = PyRPlidar()
        lidar.connect(port=str(line.path), baudrate=256000, timeout=3)
        info = lidar.get_info()
        modes = lidar.get_scan_modes()
        typical = lidar.get_scan_mode_typical()
        scan = lidar.start_scan_express(typical)
        samples = list(itertools.islice(scan(), 2000))
        lidar.stop()
        lidar.disconnect()
    assert (info.model, info.firmware_major, info.firmware_minor) == (0x61, 1, 28)
    spec = MODELS["S1"]
    assert [m.name for m in modes] == [m.name for m in spec.modes]
    assert [m.max_distance / 256 for m in modes] == [m.max_distance_m for m in spec.modes]
    assert [m.us_per_sample / 256 for m in modes] == [m.us_per_sample for m in spec.modes]
    assert [m.ans_type for m in modes] == [0x81, 0x85]  # standard samples, dense capsules
    assert spec.modes[typical].name == "DenseBoost"
    checked = 0
    for sample in samples[80:]:
        expected = _expected_mm(sample.angle)
        if expected is not None:
            assert sample.distance == pytest.approx(expected, abs=1.0)
            checked += 1
    assert checked > 1500
