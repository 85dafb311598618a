"""Pseudo-terminals that a program under test opens through a link of the test's own."""

from __future__ import annotations

import os
from pathlib import Path


def linked_pty(folder: Path, name: str = "ttyUSB0") -> tuple[int, int, Path]:
    """A new pseudo-terminal: (master fd, slave fd, a link to the slave in ``folder``).

    A program given the link rather than /dev/pts/N cannot reach another test's
    pseudo-terminal after this one is closed: the kernel hands the number out again, and a
    program that retries its port would open that one (seen with two pytest workers)."""
    master, slave = os.openpty()
    link = folder / name
    link.symlink_to(os.ttyname(slave))
    return master, slave, link
