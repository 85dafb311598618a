"""Faces that load their heavy members only when asked: a room's ``__init__`` names what other
rooms use, and a program that needs its light part (a sensor program opening a serial port,
a benchmark starting a broker) does not pay for the rest (a daemon module, numba's kernels).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping

__all__ = ["lazy_members"]


def lazy_members(package: str, members: Mapping[str, str]) -> Callable[[str], object]:
    """A module ``__getattr__`` for ``package`` that imports ``members`` (name -> the module
    under ``package`` defining it) on first use.

    A member may not share its name with a module of the package: importing that module
    (from anywhere) sets the package's attribute of that name to the module, which then
    hides the member.

    Raises:
        ValueError: a member is named like one of the modules.
        AttributeError (from the returned function): ``name`` is not one of ``members``.
    """
    clashes = sorted(set(members) & set(members.values()))
    if clashes:
        raise ValueError(f"{package}: members named like its modules: {', '.join(clashes)}")

    def member(name: str) -> object:
        module = members.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f"{package}.{module}"), name)

    return member
