from __future__ import annotations

import pytest

from navd.drivers.timesync import StampMapper


def test_offset_is_the_fastest_frame_and_never_maps_past_arrival() -> None:
    mapper = StampMapper(window_s=10.0)
    # client clock is 1000 s ahead; transport delays 5, 1, 3 ms
    arrivals = [(1.005, 1001.0), (2.001, 1002.0), (3.003, 1003.0)]
    mapped = [mapper.to_daemon(stamp, arrival) for arrival, stamp in arrivals]
    assert mapped[0] == pytest.approx(1.005)
    assert mapped[1] == pytest.approx(2.001)
    assert mapped[2] == pytest.approx(3.001)  # the 1 ms path is the best offset estimate
    assert all(m <= a + 1e-12 for m, (a, _) in zip(mapped, arrivals, strict=True))


def test_window_follows_a_clock_jump() -> None:
    mapper = StampMapper(window_s=1.0)
    assert mapper.to_daemon(100.0, 0.0) == pytest.approx(0.0)
    # the client clock jumps back by 50 s: offsets grow, the old minimum ages out
    # within the window the old (smaller) offset -100 s still rules: 50.5 - 100 = -49.5
    assert mapper.to_daemon(50.5, 0.5) == pytest.approx(-49.5)
    assert mapper.to_daemon(52.0, 2.0) == pytest.approx(2.0)


def test_missing_stamp_means_arrival_time() -> None:
    assert StampMapper().to_daemon(None, 7.25) == 7.25


def test_a_mapped_stamp_is_never_after_arrival_even_by_rounding() -> None:
    mapper = StampMapper()
    arrival = 13547.962197234
    for i in range(1000):
        stamp = 5000.0 + 0.1 * i + 1e-7 * i
        assert mapper.to_daemon(stamp, arrival + 1e-4 * i) <= arrival + 1e-4 * i
