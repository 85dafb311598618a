"""What start-up leaves in memory: freed heap handed back to the operating system, and the
objects start-up made set aside from the garbage collector's full passes."""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import gc
from collections.abc import Callable

__all__ = ["freeze_start_up_objects", "release_freed_memory"]


def freeze_start_up_objects() -> int:
    """Move every object the garbage collector tracks now into its permanent generation, and
    return how many there were.

    Called once the set-ups are done: the modules, settings, compiled kernels' wrappers and
    imported libraries live as long as the process, yet each full collection walked all of
    them again (tens of thousands of objects, about 30 ms a pass on the event loop here).
    Frozen, they are never walked; whatever of them was already garbage stays (start-up
    makes little). Nothing is collected here, so freezing costs no pause.
    """
    gc.freeze()
    return gc.get_freeze_count()


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
