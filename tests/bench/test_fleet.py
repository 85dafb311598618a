"""No robot is left paused: ``navd fleet goal``, as its own process, drives 50 vehicles
(navd's order logic on their own MQTT connections, point robots) on a real mosquitto
through two group goals in a row; both are reached and, as the vehicles themselves say,
none holds its order paused after either. Before, 15 of 50 stayed paused after the first
goal and the second timed out."""

from __future__ import annotations

import pytest

from navd.bench import fleet
from navd.sim import mosquitto_path

pytestmark = pytest.mark.e2e


def test_fifty_vehicles_reach_two_group_goals_in_a_row_and_none_is_left_paused() -> None:
    if mosquitto_path() is None:
        pytest.skip("mosquitto is not installed (apt-get install mosquitto; `make test` does)")
    figures = fleet.run(vehicles=50)
    assert [run["reached"] for run in figures["goals"]] == [True, True]
    assert [run["left_paused"] for run in figures["goals"]] == [0, 0]
    assert all(run["steps"] >= 3 for run in figures["goals"])  # they drove, step by step
