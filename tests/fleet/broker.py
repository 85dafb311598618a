"""A real MQTT broker for tests (``navd.sim.broker.LocalBroker``): tests skip, saying why,
where mosquitto is not installed (the set-up installs it where it can: root with apt)."""

from __future__ import annotations

from pathlib import Path

import pytest

from navd.sim import LocalBroker, mosquitto_path


def Broker(folder: Path) -> LocalBroker:  # noqa: N802 - reads as the class it makes
    """A broker in ``folder`` (not started), or a skip saying how to get mosquitto."""
    if mosquitto_path() is None:
        pytest.skip(
            "mosquitto is not installed (apt-get install mosquitto; `make test` does as root)"
        )
    return LocalBroker(folder)
