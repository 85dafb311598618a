"""Event and state queues: late events rewind, future events wait, old events are dropped."""

from __future__ import annotations

import numpy as np
import pytest

from navd.estimation.history import Event, EventHistory, HistorySettings, Insert
from navd.estimation.motion_model import STATE_SIZE, TH, Row, X
from navd.estimation.ukf import Measurement, PoseUkf, UkfSettings


def _history(horizon_s: float = 1.0, max_events: int = 100) -> EventHistory:
    ukf = PoseUkf(
        UkfSettings(alpha=0.1, beta=2.0, kappa=6.0, linear_jerk_psd=0.25, angular_jerk_psd=1.0)
    )
    history = EventHistory(ukf, HistorySettings(horizon_s, max_events, reset_inflation=10.0))
    history.initialize(0.0, np.zeros(STATE_SIZE), np.eye(STATE_SIZE) * 0.1)
    return history


def _event(t: float, x: float, source: str = "lidar") -> Event:
    m = Measurement(
        rows=(Row.X, Row.Y, Row.YAW),
        z=np.array([x, 0.0, 0.0]),
        r=np.diag([1e-4, 1e-4, 1e-4]),
        gated_rows=3,
    )
    return Event(t, source, m, 1e6)


EVENTS = [_event(0.1 * i, 0.05 * i) for i in range(1, 11)]


def _in_order() -> EventHistory:
    history = _history()
    for e in EVENTS:
        assert history.insert(e, e.stamp) is Insert.APPLIED
    return history


def test_a_late_event_gives_the_in_order_result() -> None:
    expected = _in_order().latest
    history = _history()
    late = EVENTS[4]
    for e in EVENTS:
        if e is not late:
            history.insert(e, e.stamp)
    assert history.insert(late, 1.0) is Insert.REPLAYED
    np.testing.assert_allclose(history.latest.x, expected.x, atol=1e-12)
    np.testing.assert_allclose(history.latest.p, expected.p, atol=1e-12)
    assert history.counters.replayed == 1
    assert history.counters.reapplied == 5


def test_a_future_event_waits_for_its_time() -> None:
    history = _history()
    assert history.insert(EVENTS[2], 0.1) is Insert.DEFERRED
    assert history.latest.stamp == 0.0
    assert history.advance(0.2) == 0
    assert history.advance(0.3) == 1
    assert history.latest.stamp == pytest.approx(0.3)
    assert history.event_count == 1


def test_events_older_than_the_horizon_are_dropped_and_counted() -> None:
    history = _history(horizon_s=0.25)
    for e in EVENTS[:6]:
        history.insert(e, e.stamp)
    before = history.latest
    assert history.insert(_event(0.3, 9.0), 0.6) is Insert.TOO_OLD
    assert history.counters.too_old == 1
    assert history.latest is before
    # Only the events inside the horizon are kept for rewinding.
    assert history.event_count == 3


def test_memory_is_bounded_by_max_events() -> None:
    history = _history(horizon_s=30.0, max_events=4)
    for e in EVENTS:
        history.insert(e, e.stamp)
    assert history.event_count == 4
    assert history.counters.overflow == 6
    for i in range(10):
        history.insert(_event(5.0 + i, 0.0), 0.0)  # all in the future
    assert history.event_count == 8
    assert history.counters.overflow == 12


def test_a_numerical_failure_resets_from_the_last_good_state() -> None:
    history = _history()
    history.insert(EVENTS[0], 0.1)
    good = history.latest
    broken = good.p.copy()
    broken[X, X] = -1.0
    history.initialize(good.stamp, good.x, broken)
    history.insert(EVENTS[1], 0.2)
    assert history.counters.resets == 1
    reset = history.latest
    np.testing.assert_array_equal(reset.x, good.x)
    assert np.all(np.linalg.eigvalsh(reset.p) > 0.0)
    assert reset.p[TH, TH] == pytest.approx(good.p[TH, TH] * 10.0)
    history.insert(EVENTS[2], 0.3)  # and it carries on
    assert history.latest.x[X] == pytest.approx(EVENTS[2].measurement.z[0], abs=0.01)
