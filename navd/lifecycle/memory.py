"""Handing memory freed by start-up back to the operating system."""

from __future__ import annotations

import ctypes
import ctypes.util

__all__ = ["release_freed_memory"]


def release_freed_memory() -> bool:
    """Ask the C allocator to return freed heap pages (glibc's ``malloc_trim``); False where
    there is no such call (another libc).

    Loading or compiling the numba kernels at start-up allocates and frees tens of MB that
    glibc keeps for reuse; after the set-ups that is resident memory the daemon never uses
    again (about 8 MB of the whole daemon's here).
    """
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    try:
        trim = ctypes.CDLL(name).malloc_trim
    except (OSError, AttributeError):
        return False
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    trim(0)
    return True
