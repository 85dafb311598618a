"""Handing memory freed by start-up back to the operating system."""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
from collections.abc import Callable

__all__ = ["release_compiler_code", "release_freed_memory"]

_MADV_DONTNEED = 4  # Linux: drop the pages; a file's clean pages are read again on next use
# The library whose code only compiling and loading kernels runs: numba's LLVM.
COMPILER_LIBRARY = "libllvmlite.so"


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


def release_compiler_code(library: str = COMPILER_LIBRARY) -> int:
    """Drop the pages of ``library``'s code and read-only data from this process's resident
    set; returns the bytes that were resident (0 where this cannot be done).

    Loading the kernels from numba's cache runs much of LLVM, and the kernel maps each page
    it runs with its neighbours: some 70 MB of LLVM's code stays resident, counted in the
    daemon's RSS, although nothing runs it again once the kernels are loaded (a kernel call
    jumps straight into its machine code). Only mappings of the file that were never written
    to are dropped (``Private_Dirty`` 0: the file's own bytes, which the kernel reads back
    from it if LLVM runs again); relocated data and anything else stay as they are.
    """
    madvise = _madvise()
    if madvise is None:
        return 0
    released = 0
    for start, end, resident in _clean_mappings(library):
        if madvise(start, end - start, _MADV_DONTNEED) == 0:
            released += resident
    return released


def _clean_mappings(library: str, smaps: str | None = None) -> list[tuple[int, int, int]]:
    """(start, end, resident bytes) of each read-only mapping of ``library`` all of whose
    pages are the file's own bytes, from ``smaps`` (default: this process's
    /proc/self/smaps; empty where there is none).

    A page the process wrote (relocated data) is dirty, or anonymous, or, swapped out, in
    ``Swap``: a mapping with any of those is left alone, as is one whose resident pages are
    not all clean.
    """
    if smaps is None:
        try:
            with open("/proc/self/smaps", encoding="utf-8", errors="replace") as file:
                smaps = file.read()
        except OSError:
            return []
    found: list[tuple[int, int, int]] = []
    for header, counts in _mappings(smaps):
        path = header[5].removesuffix(" (deleted)") if len(header) == 6 else ""
        if not path.endswith(library) or "w" in header[1]:
            continue
        written = sum(
            counts.get(key, 1) for key in ("Private_Dirty", "Shared_Dirty", "Anonymous", "Swap")
        )
        clean = counts.get("Private_Clean", 0) + counts.get("Shared_Clean", 0)
        if written == 0 and clean == counts.get("Rss", -1):
            low, high = header[0].split("-")
            found.append((int(low, 16), int(high, 16), clean * 1024))
    return found


def _mappings(smaps: str) -> list[tuple[list[str], dict[str, int]]]:
    """Each mapping of an smaps text: its header's fields (the path, spaces and all, as the
    sixth) and its counters [kB]."""
    mappings: list[tuple[list[str], dict[str, int]]] = []
    for line in smaps.splitlines():
        fields = line.split(maxsplit=5)
        if len(fields) >= 5 and "-" in fields[0] and not fields[0].endswith(":"):
            mappings.append((fields, {}))
        elif mappings and len(fields) >= 2 and fields[0].endswith(":") and fields[1].isdigit():
            mappings[-1][1][fields[0][:-1]] = int(fields[1])
    return mappings


@functools.cache
def _madvise() -> Callable[[int, int, int], int] | None:
    """libc's ``madvise``, looked up once; None where there is no such call."""
    name = ctypes.util.find_library("c")
    if name is None:
        return None
    try:
        call = ctypes.CDLL(name, use_errno=True).madvise
    except (OSError, AttributeError):
        return None
    call.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
    call.restype = ctypes.c_int
    return call
