"""The process's open-file limit: raised at start to what the system allows, since every
client, viewer and sensor is a descriptor, and the soft limit many systems start a process
with (1024) is reached by a few hundred half-open connections before any listener's own cap.
"""

from __future__ import annotations

import resource

__all__ = ["WANTED_FILES", "raise_file_limit"]

WANTED_FILES = 65536  # descriptors wanted; the hard limit may allow fewer


def raise_file_limit() -> tuple[int, int]:
    """Raise the soft RLIMIT_NOFILE towards ``WANTED_FILES`` within the hard limit.

    Returns:
        (before, after): the soft limit as it was and as it is.
    """
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    wanted = WANTED_FILES if hard == resource.RLIM_INFINITY else min(WANTED_FILES, hard)
    if soft != resource.RLIM_INFINITY and soft < wanted:
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (wanted, hard))
        except (ValueError, OSError):
            return soft, soft  # a container that refuses: the limit stays and is logged
        return soft, wanted
    return soft, soft
