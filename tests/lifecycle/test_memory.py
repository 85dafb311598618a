"""Memory handed back after start-up: LLVM's code pages leave the resident set, and
compiling still works afterwards (the pages are read back from the library file)."""

from __future__ import annotations

import numba
import numpy as np

from navd.lifecycle.memory import _clean_mappings, _mappings, release_compiler_code

SMAPS = """\
7f0000000000-7f0000001000 r--p 00000000 fe:00 11 /lib/libllvmlite.so
Size:                  4 kB
Rss:                   4 kB
Private_Dirty:         0 kB
Anonymous:             0 kB
VmFlags: rd mr mw me sd
7f0000001000-7f0000003000 r--p 00001000 fe:00 11 /lib/libllvmlite.so
Size:                  8 kB
Rss:                   8 kB
Private_Dirty:         8 kB
7f0000003000-7f0000004000 rw-p 00003000 fe:00 11 /lib/libllvmlite.so
Rss:                   4 kB
"""


def test_smaps_text_is_read_mapping_by_mapping() -> None:
    rows = _mappings(SMAPS)
    assert [header[0] for header, _ in rows] == [
        "7f0000000000-7f0000001000",
        "7f0000001000-7f0000003000",
        "7f0000003000-7f0000004000",
    ]
    assert rows[0][1] == {"Size": 4, "Rss": 4, "Private_Dirty": 0, "Anonymous": 0}
    assert rows[1][1]["Private_Dirty"] == 8  # relocated data: written, never dropped


def test_llvm_code_leaves_the_resident_set_and_compiling_still_works() -> None:
    @numba.njit(cache=False)
    def before(a: np.ndarray) -> float:
        return float(a.sum())

    assert before(np.arange(4.0)) == 6.0  # LLVM has run in this process
    resident = sum(r for _, _, r in _clean_mappings("libllvmlite.so"))
    assert resident > 1 << 20
    released = release_compiler_code()
    assert released >= resident // 2
    after_drop = sum(r for _, _, r in _clean_mappings("libllvmlite.so"))
    assert after_drop < resident // 4

    @numba.njit(cache=False)
    def after(a: np.ndarray) -> float:
        return float((a * a).sum())

    assert after(np.arange(4.0)) == 14.0  # compiled with the pages read back
    assert before(np.arange(3.0)) == 3.0


def test_a_library_not_loaded_releases_nothing() -> None:
    assert release_compiler_code("libnot-loaded-here.so") == 0
