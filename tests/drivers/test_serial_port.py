"""Opening a serial port exclusively, on a real pseudo-terminal."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import serial

from navd.drivers.serial_port import PortInUseError, open_exclusive


@pytest.fixture
def port(tmp_path: Path) -> str:
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


def test_a_lock_held_by_a_program_that_is_not_navd_is_respected(port: str) -> None:
    other = serial.Serial(port, 9600, exclusive=True)  # e.g. a terminal program
    try:
        with pytest.raises(PortInUseError):
            open_exclusive(port, 115200)
    finally:
        other.close()


def test_a_missing_port_is_not_mistaken_for_a_busy_one(tmp_path: Path) -> None:
    with pytest.raises(serial.SerialException) as caught:
        open_exclusive(str(tmp_path / "ttyNONE"), 115200)
    assert not isinstance(caught.value, PortInUseError)
    assert "ttyNONE" in str(caught.value)
