"""A map folder of the robot's own disk (``save_map``/``load_map`` with ``folder``) is taken
from a client on the robot, and refused by name to one elsewhere unless the config trusts
control clients with privileged changes."""

from __future__ import annotations

from pathlib import Path

import pytest

from navd.drivers.client import AsyncClient
from navd.drivers.protocol.frames import LoadMapFrame, SaveMapFrame
from navd.drivers.protocol.replies import Ack, ErrorFrame
from navd.lifecycle.messages import LoadMapRequest, SaveMapRequest
from tests.drivers.conftest import record, running_daemon, until
from tests.viz.test_commands import _address_beyond_loopback

TOKEN = "a-token-of-twenty-chars"


async def test_a_folder_is_taken_from_this_machine(tmp_path: Path) -> None:
    async with running_daemon() as (daemon, port):
        saves = record(daemon, SaveMapRequest)
        client = await AsyncClient.connect("127.0.0.1", port, device_id="here")
        answer = await client.request(SaveMapFrame(name="lab", folder=str(tmp_path)))
        assert isinstance(answer, Ack)
        await until(lambda: len(saves) == 1)
        assert saves[0].folder == str(tmp_path) and saves[0].name == "lab"
        await client.close()


@pytest.mark.parametrize("privileged", [False, True])
async def test_a_folder_from_elsewhere_needs_privileged_changes(
    tmp_path: Path, privileged: bool
) -> None:
    address = _address_beyond_loopback()
    if address is None:
        pytest.skip("this machine has no address beyond loopback to connect from")
    tcp = {"host": "0.0.0.0", "token": TOKEN, "allow_privileged_changes": privileged}
    async with running_daemon(tcp=tcp) as (daemon, port):
        loads = record(daemon, LoadMapRequest)
        client = await AsyncClient.connect(address, port, device_id="away", token=TOKEN)
        client.send(LoadMapFrame(name="lab", folder=str(tmp_path)))
        answer = await client.receive(3.0)
        if privileged:
            assert isinstance(answer, Ack)
            await until(lambda: len(loads) == 1)
        else:
            assert isinstance(answer, ErrorFrame) and answer.field == "folder"
            assert "only from this machine" in answer.reason and not answer.fatal
            assert loads == []
        await client.close()
