"""The RPLIDAR driver against the emulated device: the conversation (health, info, motor,
scan), standard and express turns as ROS scans, and bad bytes, checksums and health."""

from __future__ import annotations

import functools
import math
import operator

import numpy as np
import pytest

from navd.sensors.rplidar import Command, RplidarDecoder, ScanMode, request
from navd.wire import ScanFrame
from tests.sensors.rplidar_emulator import RplidarEmulator, sample


def room(angle_cw_deg: float) -> float:
    """A wall 1 m away on the lidar's right (80-100 deg clockwise), 3 m elsewhere; nothing
    comes back from straight behind (175-185 deg)."""
    if 175.0 <= angle_cw_deg <= 185.0:
        return 0.0
    return 1.0 if 80.0 <= angle_cw_deg <= 100.0 else 3.0


def _connected(mode: ScanMode, **device: object) -> tuple[RplidarDecoder, RplidarEmulator]:
    """A decoder talking to an emulated lidar until the lidar streams."""
    emulator = RplidarEmulator(room, **device)  # type: ignore[arg-type]
    decoder = RplidarDecoder(mode)
    outbox: list[bytes] = []
    decoder.opened(outbox.append, lambda level: None)
    for _ in range(5):  # each answer may ask the next question
        sent, outbox[:] = b"".join(outbox), []
        answer = emulator.hear(sent)
        decoder.feed(answer, 0.0)
    return decoder, emulator


def _at(scan: ScanFrame, angle_rad: float) -> float | None:
    assert scan.ranges is not None
    k = round((angle_rad - scan.angle_min) / scan.angle_increment) % len(scan.ranges)
    window = [scan.ranges[(k + d) % len(scan.ranges)] for d in (-1, 0, 1)]
    found = [r for r in window if r is not None]
    return min(found) if found else None


def test_a_request_with_a_payload_carries_its_size_and_xor_checksum() -> None:
    assert request(Command.STOP) == b"\xa5\x25"
    pwm = request(Command.SET_MOTOR_PWM, (660).to_bytes(2, "little"))
    assert pwm[:5] == bytes([0xA5, 0xF0, 2, 0x94, 0x02])
    assert pwm[5] == functools.reduce(operator.xor, pwm[:5])


def test_the_conversation_asks_health_and_info_starts_the_motor_and_the_scan() -> None:
    decoder, emulator = _connected(ScanMode.STANDARD, model=0x28)
    assert emulator.requests == [0x25, 0x52, 0x50, 0xF0, 0x20]  # stop, health, info, PWM, scan
    assert emulator.pwm == [660]
    assert decoder.info is not None and decoder.info.series == "A2"
    assert decoder.info.firmware == "1.29" and decoder.info.serial == bytes(range(16)).hex().upper()
    assert emulator.streaming == "standard"
    # an A1 spins by DTR alone: no PWM
    _, a1 = _connected(ScanMode.STANDARD, model=0x18)
    assert 0xF0 not in a1.requests and a1.streaming == "standard"


@pytest.mark.parametrize("mode", [ScanMode.STANDARD, ScanMode.EXPRESS])
def test_a_turn_becomes_one_counter_clockwise_scan(mode: ScanMode) -> None:
    decoder, emulator = _connected(mode)
    scans = []
    for t in range(4):
        scans += decoder.feed(emulator.turn(), stamp=10.0 + 0.1 * t)
    assert len(scans) >= 2
    scan = scans[1]
    assert isinstance(scan, ScanFrame) and scan.angle_min == -math.pi
    # the wall on the lidar's right (clockwise 90 deg) is at -90 deg in the ROS convention
    assert _at(scan, -math.pi / 2) == pytest.approx(1.0, abs=0.002)
    assert _at(scan, math.pi / 2) == pytest.approx(3.0, abs=0.002)
    assert _at(scan, 0.0) == pytest.approx(3.0, abs=0.002)
    assert _at(scan, math.pi) is None  # no return behind
    assert scan.stamp in (10.0, 10.1, 10.2)  # the stamp of the bytes that began the turn
    assert decoder.skipped_bytes == 0 and decoder.bad_checksums == 0


def test_express_offsets_put_each_sample_at_its_true_angle() -> None:
    """A narrow post (1 m at 45-46 deg clockwise): only the offset-corrected angles put the
    express samples on it."""
    post = lambda a: 1.0 if 45.0 <= a <= 46.0 else 3.0  # noqa: E731
    emulator = RplidarEmulator(post)
    decoder = RplidarDecoder(ScanMode.EXPRESS)
    outbox: list[bytes] = []
    decoder.opened(outbox.append, lambda level: None)
    for _ in range(5):
        sent, outbox[:] = b"".join(outbox), []
        decoder.feed(emulator.hear(sent), 0.0)
    scans = [s for t in range(3) for s in decoder.feed(emulator.turn(), 0.1 * t)]
    scan = scans[-1]
    assert scan.ranges is not None
    angles = scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
    near = [math.degrees(-a) for a, r in zip(angles, scan.ranges, strict=True) if r == 1.0]
    assert near and all(44.5 <= a <= 46.5 for a in near)


def test_garbage_and_broken_samples_are_skipped_and_counted() -> None:
    decoder, emulator = _connected(ScanMode.STANDARD)
    turn = bytearray(emulator.turn())
    turn[7] ^= 0x01  # the check bit of the second sample
    noisy = b"\x00\xff\x13" + bytes(turn) + emulator.turn() + emulator.turn()
    scans = decoder.feed(noisy, 1.0)
    assert decoder.skipped_bytes >= 3
    assert scans and _at(scans[-1], -math.pi / 2) == pytest.approx(1.0, abs=0.002)


def test_an_express_capsule_with_a_wrong_checksum_is_dropped_and_counted() -> None:
    decoder, emulator = _connected(ScanMode.EXPRESS)
    turn = bytearray(emulator.turn())
    turn[84 * 3 + 20] ^= 0x40  # a distance inside the fourth capsule
    decoder.feed(bytes(turn) + emulator.turn() + emulator.turn(), 1.0)
    assert decoder.bad_checksums == 1


def test_a_health_error_resets_the_lidar_and_is_counted() -> None:
    decoder, emulator = _connected(ScanMode.STANDARD, health=2)
    assert decoder.health_errors == 1
    assert Command.RESET in emulator.requests and emulator.streaming is None
    # fallen silent, the driver asks again: healthy after the reset, it streams
    outbox: list[bytes] = []
    decoder.opened(outbox.append, lambda level: None)
    for _ in range(5):
        sent, outbox[:] = b"".join(outbox), []
        decoder.feed(emulator.hear(sent), 0.0)
    assert emulator.streaming == "standard"


def test_a_sample_cut_mid_turn_waits_for_the_rest() -> None:
    decoder, emulator = _connected(ScanMode.STANDARD)
    data = emulator.turn() + emulator.turn() + sample(0.0, 2.0, start=True)
    assert len(decoder.feed(data[:1003], 1.0)) == 0  # a sample cut in two: kept, not skipped
    assert len(decoder.feed(data[1003:], 1.1)) == 2
    assert decoder.skipped_bytes == 0
