"""Opening a serial port exclusively, on a real pseudo-terminal."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial

from navd.drivers.serial_port import PortInUseError, open_exclusive


@pytest.fixture
def port(tmp_path: Path) -> Iterator[str]:
    master, slave = os.openpty()
    link = tmp_path / "ttyTEST"
    link.symlink_to(os.ttyname(slave))
    yield str(link)
    os.close(slave)
    os.close(master)


def test_a_second_opener_is_refused_by_name_until_the_first_closes(port: str) -> None:
    first = open_exclusive(port, 115200, timeout=0)
    with pytest.raises(PortInUseError, match=r"ttyTEST is in use by another program"):
        open_exclusive(port, 115200, timeout=0)
    first.close()
    second = open_exclusive(port, 115200, timeout=0)
    assert second.is_open
    second.close()


def test_a_lock_held_by_another_process_is_respected(port: str) -> None:
    # another process that locks its ports the same way (flock), as picocom does
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import fcntl, os, sys; fd = os.open(sys.argv[1], os.O_RDWR | os.O_NOCTTY); "
            "fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB); print('locked', flush=True); "
            "sys.stdin.read()",
            port,
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "locked"
        with pytest.raises(PortInUseError, match="fuser -v"):
            open_exclusive(port, 115200)
    finally:
        holder.communicate("", timeout=10)
    open_exclusive(port, 115200).close()  # the holder is gone: so is its lock


def test_a_missing_port_is_not_mistaken_for_a_busy_one(tmp_path: Path) -> None:
    with pytest.raises(serial.SerialException) as caught:
        open_exclusive(str(tmp_path / "ttyNONE"), 115200)
    assert not isinstance(caught.value, PortInUseError)
    assert "ttyNONE" in str(caught.value)


def test_a_port_without_permission_is_not_called_busy(
    port: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    def refused(*_: object) -> int:
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(serial.serialposix.os, "open", refused)  # not in the dialout group
    with pytest.raises(serial.SerialException, match="Permission denied") as caught:
        open_exclusive(port, 115200)
    assert not isinstance(caught.value, PortInUseError)
