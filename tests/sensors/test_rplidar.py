"""The RPLIDAR program's side against the emulated device (``navd.sim.devices``, itself read
by the rplidar and pyrplidar packages): the conversation each model needs, Slamtec's request
spacing, the scan modes and ranges a lidar describes, turns as scans, and what it does when
the lidar is unhealthy, silent or speaks garbage. Time is the test's own clock."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navd.sensors.rplidar import ANSWER_TIMEOUT_S, RESET_SETTLE_S, RplidarDecoder
from navd.sensors.rplidar_protocol import Command, request
from navd.sim.devices import MODELS, RplidarDevice
from navd.wire import ScanFrame


def room(angle_cw_deg: float) -> tuple[float, int]:
    """A wall 1 m away on the lidar's right (80-100 deg clockwise), 3 m elsewhere; nothing
    comes back from straight behind (175-185 deg)."""
    if 175.0 <= angle_cw_deg <= 185.0:
        return 0.0, 0
    return (1.0, 47) if 80.0 <= angle_cw_deg <= 100.0 else (3.0, 20)


class Line:
    """The decoder and the device joined by a line, on the test's clock: what the decoder
    writes reaches the device at once; what the device streams reaches the decoder once its
    bytes have crossed the line (at the model's baud rate), at the next step."""

    def __init__(self, model: str, mode: str | None = None, **device: object) -> None:
        self.now = 100.0
        self.device = RplidarDevice(room, model=model, **device)  # type: ignore[arg-type]
        self.notes: list[tuple[str, dict[str, object]]] = []
        self.decoder = RplidarDecoder(
            mode,
            baud=MODELS[model].baud,
            notes=lambda event, fields: self.notes.append((event, fields)),
            clock=lambda: self.now,
            sleep=self._sleep,
        )
        self.to_decoder = b""
        self.mute = False  # the device hears but its answers are lost
        self.writes: list[tuple[float, bytes]] = []
        self.scans: list[ScanFrame] = []
        self.decoder.opened(self._write, lambda level: None)

    def _sleep(self, seconds: float) -> None:
        self.now += seconds

    def _write(self, data: bytes) -> None:
        self.writes.append((self.now, data))
        answer = self.device.hear(data, self.now)
        if not self.mute:
            self.to_decoder += answer

    def run(self, seconds: float, step_s: float = 0.001) -> None:
        end = self.now + seconds
        while self.now < end:
            self.now += step_s
            unit = 5 if self.device.streaming == 0x81 else 84  # a sample, or a capsule
            crossed = self.now - unit * 10 / MODELS[self.device.model].baud
            streamed, _ = self.device.stream_until(crossed)
            data, self.to_decoder = self.to_decoder + (b"" if self.mute else streamed), b""
            if data:
                self.scans += self.decoder.feed(data, self.now)  # type: ignore[arg-type]
            self.decoder.tick(self.now)

    def events(self) -> list[str]:
        return [event for event, _ in self.notes]


def _at(scan: ScanFrame, angle_rad: float) -> float | None:
    """The nearest return within a ray of ``angle_rad`` (counter-clockwise)."""
    assert scan.ranges is not None
    k = round((angle_rad - scan.angle_min) / scan.angle_increment) % len(scan.ranges)
    window = [scan.ranges[(k + d) % len(scan.ranges)] for d in (-1, 0, 1)]
    found = [r for r in window if r is not None]
    return min(found) if found else None


@pytest.mark.parametrize(
    ("model", "mode", "range_max"),
    [
        ("A1", "Express", 12.0),  # its typical mode
        ("A2", "Express", 12.0),
        ("S1", "DenseBoost", 40.0),
        ("C1", "DenseBoost", 12.0),
        ("A3", "Express", 25.0),  # typical Sensitivity comes in ultra capsules: the fastest
        ("A1-old", "Standard", 12.0),  # firmware 1.20 does not describe its modes
    ],
)
def test_each_model_is_asked_its_modes_and_runs_the_right_one(
    model: str, mode: str, range_max: float
) -> None:
    line = Line(model)
    line.run(1.0)
    device, decoder = line.device, line.decoder
    assert device.requests[:3] == [Command.STOP, Command.GET_HEALTH, Command.GET_INFO]
    assert (Command.SET_MOTOR_PWM in device.requests) == (model in ("A2", "A3"))
    assert decoder.scan_mode is not None and decoder.scan_mode.name == mode
    assert decoder.turns.range_max_m == range_max
    assert device.streaming is not None and device.deaf_requests == []
    assert len(line.scans) >= 3
    scan = line.scans[-1]
    assert scan.range_max == range_max
    # the wall on the lidar's right (clockwise 90 deg) is at -90 deg in the ROS convention
    assert _at(scan, -math.pi / 2) == pytest.approx(1.0, abs=0.002)
    assert _at(scan, math.pi / 2) == pytest.approx(3.0, abs=0.002)
    assert _at(scan, math.pi) is None  # no return behind


def test_no_request_follows_a_stop_within_a_millisecond() -> None:
    line = Line("A1")
    line.run(0.5)
    stops = [at for at, data in line.writes if data == request(Command.STOP)]
    for stop in stops:
        after = [
            at for at, data in line.writes if at > stop - 1e-12 and data != request(Command.STOP)
        ]
        assert not after or min(after) - stop >= 0.001
    assert line.device.deaf_requests == []


def test_a_scan_mode_is_chosen_by_name_or_refused_with_what_there_is() -> None:
    standard = Line("S1", mode="standard")
    standard.run(1.0)
    assert standard.decoder.scan_mode is not None
    assert standard.decoder.scan_mode.name == "Standard"
    assert Command.SCAN in standard.device.requests
    refused = Line("A3", mode="sensitivity")
    refused.run(1.0)
    assert refused.device.streaming is None
    ((_, fields),) = [n for n in refused.notes if n[0] == "lidar_scan_mode_refused"]
    assert fields["readable"] == ["Standard", "Express"]


def test_turns_are_stamped_when_they_were_measured_and_in_order() -> None:
    line = Line("A2")
    line.run(1.2, step_s=0.004)  # bytes read every 4 ms: a turn's end comes within a read
    assert len(line.scans) >= 8
    truth = [t.first_s for t in line.device.turns]
    for scan in line.scans[2:]:
        nearest = min(truth, key=lambda t: abs(t - scan.stamp))
        assert scan.stamp == pytest.approx(nearest, abs=0.003)
        assert scan.angle_increment < 0 and scan.time_increment == pytest.approx(
            0.1 / len(scan.ranges or []), rel=0.1
        )


def test_a_health_error_resets_the_lidar_and_its_banner_is_not_bad_input() -> None:
    line = Line("A1", health=2)
    line.run(0.1)
    assert line.decoder.health_errors == 1
    assert Command.RESET in line.device.requests and line.device.streaming is None
    line.run(RESET_SETTLE_S + 0.6)
    assert "lidar_reset_banner" in line.events()
    assert line.device.streaming is not None and line.scans
    assert line.decoder.skipped_bytes == 0 and line.decoder.banner_bytes > 0


def test_a_lidar_that_does_not_answer_is_asked_again_then_reset() -> None:
    line = Line("A1")
    line.mute, line.to_decoder = True, b""  # its answer to the first GET_HEALTH is lost too
    line.run(3 * ANSWER_TIMEOUT_S + 0.2)
    said = [f for e, f in line.notes if e == "lidar_not_answering"]
    assert said and said[0]["asked"] == "GET_HEALTH"
    assert Command.RESET in line.device.requests  # after three unanswered rounds
    line.mute = False
    line.run(RESET_SETTLE_S + 1.0)
    assert line.device.streaming is not None


def test_garbage_and_broken_samples_are_skipped_and_counted() -> None:
    line = Line("A1", mode="standard")
    line.run(0.5)
    good = len(line.scans)
    line.to_decoder = b"\x00\xff\x13"
    line.run(0.05)
    data, _ = line.device.stream_until(line.now + 0.01)
    broken = bytearray(data)
    broken[7] ^= 0x01  # the check bit of the second sample
    line.decoder.feed(bytes(broken), line.now)
    line.run(0.5)
    assert line.decoder.counts()["skipped_bytes"] >= 3
    assert len(line.scans) > good


def test_an_express_capsule_with_a_wrong_checksum_is_dropped_and_counted() -> None:
    line = Line("A2")
    line.run(0.3)
    data, _ = line.device.stream_until(line.now + 0.05)
    broken = bytearray(data)
    broken[84 * 3 + 20] ^= 0x40  # a distance inside the fourth capsule
    line.decoder.feed(bytes(broken), line.now)
    assert line.decoder.counts()["bad_checksums"] == 1


def test_express_offsets_put_each_sample_at_its_true_angle() -> None:
    """A narrow post (1 m at 45-46 deg clockwise): only offset-corrected angles put the
    express samples on it."""
    line = Line("A2")
    line.device.room = lambda a: (1.0, 0) if 45.0 <= a <= 46.0 else (3.0, 0)
    line.run(0.6)
    scan = line.scans[-1]
    assert scan.ranges is not None
    angles = scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
    near = [math.degrees(-a) % 360 for a, r in zip(angles, scan.ranges, strict=True) if r == 1.0]
    assert near and all(44.5 <= a <= 46.5 for a in near)
