"""A map folder of the robot's own disk (``save_map``/``load_map`` with ``folder``) is as
privileged as ``slam.map_dir``: taken only where the config trusts control clients with
privileged changes, refused by name otherwise."""

from __future__ import annotations

from pathlib import Path

import pytest

from navd.lifecycle.messages import LoadMapRequest, SaveMapRequest
from navd.wire import Ack, AsyncClient, ErrorFrame, LoadMapFrame, SaveMapFrame
from tests.drivers.conftest import record, running_daemon, until


@pytest.mark.parametrize("privileged", [False, True])
async def test_a_folder_needs_privileged_changes(tmp_path: Path, privileged: bool) -> None:
    async with running_daemon(tcp={"allow_privileged_changes": privileged}) as (daemon, port):
        saves, loads = record(daemon, SaveMapRequest), record(daemon, LoadMapRequest)
        client = await AsyncClient.connect("127.0.0.1", port, device_id="here")
        client.send(SaveMapFrame(name="lab", folder=str(tmp_path)))
        client.send(LoadMapFrame(name="lab", folder=str(tmp_path)))
        answers = [await client.receive(3.0), await client.receive(3.0)]
        if privileged:
            assert all(isinstance(a, Ack) for a in answers)
            await until(lambda: len(saves) == 1 and len(loads) == 1)
            assert saves[0].folder == str(tmp_path) and loads[0].folder == str(tmp_path)
        else:
            for answer in answers:
                assert isinstance(answer, ErrorFrame) and answer.field == "folder"
                assert "tcp.allow_privileged_changes" in answer.reason and not answer.fatal
            assert saves == [] and loads == []
        # without a folder, slam.map_dir: anyone may save there
        assert isinstance(await client.request(SaveMapFrame(name="lab")), Ack)
        await client.close()
