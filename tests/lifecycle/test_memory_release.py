"""Memory handed back after start-up: which mappings of LLVM's library may leave the
resident set, and that a process that dropped them still runs and compiles kernels."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from navd.lifecycle.memory_release import _clean_mappings, release_compiler_code

LIB = "/venv/llvmlite/binding/libllvmlite.so"


def _mapping(span: str, perms: str, path: str, **counts: int) -> str:
    rows = {"Rss": 8, "Private_Clean": 8, "Private_Dirty": 0, "Shared_Clean": 0}
    rows |= {"Shared_Dirty": 0, "Anonymous": 0, "Swap": 0} | counts
    body = "".join(f"{key}: {value} kB\n" for key, value in rows.items())
    return f"{span} {perms} 00000000 fe:00 11 {path}\n{body}VmFlags: rd mr mw me sd\n"


@pytest.mark.parametrize(
    ("perms", "path", "counts", "dropped"),
    [
        ("r-xp", LIB, {}, True),  # its code, every page clean
        ("r--p", LIB, {}, True),  # read-only data
        ("r--p", f"{LIB} (deleted)", {}, True),  # upgraded under the running process
        ("r--p", "/opt/my venv/llvmlite/libllvmlite.so", {}, True),  # a path with a space
        ("rw-p", LIB, {}, False),  # writable
        ("r--p", LIB, {"Private_Dirty": 8, "Private_Clean": 0}, False),  # relocated
        ("r--p", LIB, {"Anonymous": 8}, False),
        ("r--p", LIB, {"Swap": 8, "Rss": 0, "Private_Clean": 0}, False),  # written, swapped
        ("r--p", LIB, {"Rss": 8, "Private_Clean": 4}, False),  # pages not all accounted clean
        ("r-xp", "/usr/lib/libc.so.6", {}, False),  # another library
        ("r-xp", "", {}, False),  # anonymous memory has no path
    ],
)
def test_only_never_written_read_only_mappings_of_the_library_are_dropped(
    perms: str, path: str, counts: dict[str, int], dropped: bool
) -> None:
    smaps = _mapping("7f0000000000-7f0000002000", perms, path, **counts)
    found = _clean_mappings("libllvmlite.so", smaps)
    assert found == ([(0x7F0000000000, 0x7F0000002000, 8 * 1024)] if dropped else [])


def test_a_library_not_loaded_releases_nothing() -> None:
    assert release_compiler_code("libnot-loaded-here.so") == 0


@pytest.mark.skipif(not Path("/proc/self/smaps").exists(), reason="needs Linux /proc smaps")
def test_llvm_code_leaves_the_resident_set_and_compiling_still_works() -> None:
    """In a process of its own (no other test's thread may compile meanwhile)."""
    code = """
import numba, numpy as np
from navd.lifecycle.memory_release import _clean_mappings, release_compiler_code

def resident():
    return sum(r for _, _, r in _clean_mappings("libllvmlite.so"))

@numba.njit(cache=False)
def before(a):
    return a.sum()

assert before(np.arange(4.0)) == 6.0  # LLVM has run
was = resident()
released = release_compiler_code()
after_drop = resident()

@numba.njit(cache=False)
def after(a):
    return (a * a).sum()

assert after(np.arange(4.0)) == 14.0  # compiled with the pages read back
assert before(np.arange(3.0)) == 3.0
print(was, released, after_drop)
"""
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 0, done.stderr
    was, released, after_drop = map(int, done.stdout.split())
    assert was > 1 << 20
    assert released >= was // 2
    assert after_drop < was // 4
