"""What every planning test starts from."""

from __future__ import annotations

import pytest

from navd.config import NavdConfig
from navd.planning.guard import warm_up_guard
from navd.planning.settings import guard_settings


@pytest.fixture(autouse=True, scope="session")
def _guard_kernels_loaded() -> None:
    """The guard's kernels loaded, as the daemon's warm-up does before the robot may move
    (until then the guard stops every command, see ``guard_scale``)."""
    warm_up_guard(guard_settings(NavdConfig()))
