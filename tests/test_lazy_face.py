"""Faces whose heavy members load on first use: a member loads only when asked for, is the
object its module defines, and never a module of the same name."""

from __future__ import annotations

import subprocess
import sys
import types

import pytest

import navd.drivers
import navd.sim
from navd.lazy_face import lazy_members


def test_a_member_named_like_a_module_of_its_package_is_refused() -> None:
    with pytest.raises(ValueError, match="named like its modules: session"):
        lazy_members("navd.sim", {"session": "session", "Session": "session"})


def test_an_unknown_name_is_an_attribute_error_naming_it() -> None:
    with pytest.raises(AttributeError, match="has no attribute 'Simulator'"):
        navd.sim.Simulator  # noqa: B018 - the lookup is the test


@pytest.mark.parametrize("face", [navd.sim, navd.drivers], ids=lambda f: f.__name__)
def test_every_member_of_a_lazy_face_is_what_its_module_defines_not_a_module(
    face: types.ModuleType,
) -> None:
    for name in face.__all__:
        member = getattr(face, name)
        assert not isinstance(member, types.ModuleType), f"{face.__name__}.{name} is a module"


def test_a_sensor_program_loads_no_numba_and_no_daemon_module() -> None:
    # In a process of its own: this one has loaded everything already.
    code = (
        "import sys; import navd.drivers, navd.sim; from navd.sensors import ld06; "
        "from navd.sim import free_port; free_port(); "
        "print(sorted(m for m in sys.modules if m == 'numba' or m.startswith('navd.slam') "
        "or m == 'navd.sim.runner'))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
