"""The keys of ``navd teleop``: what each asks for, how long a held key lasts, and the stop
once it is released."""

from __future__ import annotations

import pytest

from navd.cli.teleop import DOWN, HOLD_S, LEFT, RIGHT, UP, KeyDriver, split_keys


def test_arrow_sequences_are_read_whole_and_other_bytes_one_by_one() -> None:
    assert split_keys(UP + b" " + LEFT + b"q") == ([UP, b" ", LEFT, b"q"], b"")
    # a sequence cut by the end of a read is kept for the next one
    keys, rest = split_keys(b"q" + UP[:2])
    assert (keys, rest) == ([b"q"], UP[:2])
    assert split_keys(rest + UP[2:] + DOWN) == ([UP, DOWN], b"")


@pytest.mark.parametrize(
    ("key", "command"),
    [(UP, (0.3, 0.0)), (DOWN, (-0.3, 0.0)), (LEFT, (0.0, 0.8)), (RIGHT, (0.0, -0.8))],
)
def test_each_arrow_asks_for_its_motion_while_held(
    key: bytes, command: tuple[float, float]
) -> None:
    keys = KeyDriver(0.3, 0.8)
    assert keys.command(0.0) is None  # nothing pressed: nothing sent
    keys.key(key, 1.0)
    assert keys.command(1.0) == command
    assert keys.command(1.0 + HOLD_S) == command
    # released (no repeat came): one zero at once, then nothing (the daemon's deadman)
    assert keys.command(1.0 + HOLD_S + 0.01) == (0.0, 0.0)
    assert keys.command(1.2 + HOLD_S) is None


def test_repeats_of_a_held_key_keep_it_going() -> None:
    keys = KeyDriver(0.3, 0.8)
    for i in range(20):
        keys.key(UP, 0.05 * i)
    assert keys.command(0.95 + HOLD_S - 0.01) == (0.3, 0.0)


def test_space_stops_at_once_and_speed_keys_scale_the_motion() -> None:
    keys = KeyDriver(0.4, 1.0)
    keys.key(UP, 0.0)
    keys.key(b"+", 0.1)
    linear, angular = keys.command(0.1) or (None, None)
    assert linear == pytest.approx(0.5) and angular == 0.0
    keys.key(b" ", 0.2)
    assert keys.command(0.2) == (0.0, 0.0)
    assert keys.command(0.3) == (0.0, 0.0)  # the stop is said once more, then silence
    assert keys.command(0.4) is None
    keys.key(b"-", 0.5)
    keys.key(LEFT, 0.5)
    assert keys.command(0.5) == (0.0, pytest.approx(1.0))


def test_q_and_ctrl_c_quit() -> None:
    for key in (b"q", b"\x03"):
        keys = KeyDriver(0.3, 0.8)
        keys.key(key, 0.0)
        assert keys.quit


def test_e_engages_the_emergency_stop_and_r_releases_it() -> None:
    keys = KeyDriver(0.3, 0.8)
    keys.key(UP, 0.0)
    keys.key(b"e", 0.05)
    assert keys.stop_request is True and keys.command(0.06) == (0.0, 0.0)
    keys.stop_request = None  # sent
    keys.key(b"r", 1.0)
    assert keys.stop_request is False
