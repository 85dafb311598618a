"""Handing memory freed by start-up back to the operating system."""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
from collections.abc import Callable

__all__ = ["release_freed_memory"]


def release_freed_memory() -> bool:
    """Ask the C allocator to return freed heap pages (glibc's ``malloc_trim``); False where
    there is no such call (another libc).

    Loading or compiling the numba kernels at start-up allocates and frees tens of MB that
    glibc keeps for reuse; after the set-ups that is resident memory the daemon never uses
    again (about 8 MB of the whole daemon's here).
    """
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    """glibc's ``malloc_trim``, looked up once (finding the library reads the linker cache)."""
    name = ctypes.util.find_library("c")
    if name is None:
        return None
    try:
        trim = ctypes.CDLL(name).malloc_trim
    except (OSError, AttributeError):
        return None
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    return trim
