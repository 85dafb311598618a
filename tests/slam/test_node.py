"""The SLAM module in a running daemon: scans over TCP become poses, the map is saved on request."""

from __future__ import annotations

import asyncio
import itertools
import math
from collections.abc import Callable
from pathlib import Path

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2
from navd.lifecycle.messages import (
    InitialPose,
    LocalizationState,
    MapUpdate,
    PoseEstimate,
    PoseFound,
    PoseMeasurement,
    SafeStop,
    SafeStopCleared,
    SlamTracking,
    TrackingLost,
)
from navd.slam.map_io import load_map, load_map_state
from navd.slam.node import SlamNode
from navd.wire import (
    ConfigAppliedFrame,
    ConfigFrame,
    FindPoseFrame,
    InitialPoseFrame,
    MapSavedFrame,
    SaveMapFrame,
    ScanFrame,
    StatusFrame,
    SubscribeFrame,
    UnsubscribeFrame,
)
from tests.drivers.conftest import connected, record, running_daemon, until

# slam matching keys are privileged: the client changing them is trusted by the config
TRUSTED = {"allow_privileged_changes": True}


def _frame(pose: Pose2, stamp: float) -> ScanFrame:
    a0, inc, r = cast(pose, beams=360)
    ranges = [None if not math.isfinite(v) else round(float(v), 3) for v in r]
    return ScanFrame(
        stamp=stamp,
        angle_min=a0,
        angle_increment=inc,
        range_min=0.1,
        range_max=30.0,
        ranges=ranges,
    )


async def test_scans_become_poses_and_the_map_is_saved(tmp_path: Path) -> None:
    slam = {"map_dir": str(tmp_path), "max_range_m": 20.0}
    async with running_daemon(slam=slam) as (daemon, port):
        poses = record(daemon, PoseMeasurement)
        maps = record(daemon, MapUpdate)
        estimates = record(daemon, PoseEstimate)
        tracking = record(daemon, SlamTracking)
        lidar = await connected(port, "lidar", "lidar0")
        control = await connected(port, "control", "ui")
        path = [Pose2(0.04 * i, 0.02 * i, 0.01 * i) for i in range(15)]
        for i, truth in enumerate(path):
            lidar.send(_frame(truth, 10.0 + 0.1 * i))
            await until(lambda n=i: len(poses) > n, timeout_s=10.0)
            await asyncio.sleep(0.1)  # a 10 Hz lidar
        # The first scan anchors the map at the origin; the rest are matched onto it.
        for measured, truth in zip(poses, path, strict=True):
            assert math.hypot(measured.x_m - truth.x, measured.y_m - truth.y) < 0.05
            assert abs(measured.yaw_rad - truth.yaw) < math.radians(1.5)
        assert maps and maps[0].occupancy.max() > 65
        # Tracking's counts go out at most once a second: every scan after the first (which
        # anchors the map) matched, none was doubtful.
        assert tracking
        assert all(b.stamp - a.stamp >= 1.0 for a, b in itertools.pairwise(tracking))
        for sent in tracking:
            counts = sent.counts
            assert counts["scans"] == counts["matched"] + 1
            assert counts["weak_matches"] == counts["doubtful"] == counts["repaired"] == 0
        # ... and a control client sees the latest in its status.
        await control.request(SubscribeFrame(rate_hz=20))
        status = await control.receive_type(StatusFrame)
        assert status.diagnostics.slam is not None
        assert status.diagnostics.slam["scans"] == tracking[-1].counts["scans"]
        await control.request(UnsubscribeFrame())

        # The robot stops at the path's end; the estimator (built beside start-up) takes the
        # lidar poses and settles there.
        def settled() -> bool:
            last = path[-1]
            return any(math.hypot(e.x_m - last.x, e.y_m - last.y) < 0.05 for e in estimates[-3:])

        for i in range(100):
            lidar.send(_frame(path[-1], 11.5 + 0.1 * i))
            await asyncio.sleep(0.1)
            if settled():
                break
        assert settled()
        await control.request(SaveMapFrame(name="lab"))
        await until((tmp_path / "lab.yaml").exists, timeout_s=10.0)
        grid = load_map(tmp_path / "lab.yaml")
        assert grid.to_array().max() > 0
        # ... with the pose graph it was built from, for a later run to go on mapping
        saved = load_map_state(tmp_path / "lab.yaml")
        (node,) = [m for m in daemon.manager.modules if isinstance(m, SlamNode)]
        assert saved.graph is not None
        assert len(saved.graph.keyframes) == len(node.mapper.keyframes) > 1
        await lidar.close()
        await control.close()
        await asyncio.sleep(0)


async def test_the_map_is_saved_on_shutdown_only_once_one_was_drawn(tmp_path: Path) -> None:
    # save_on_shutdown: a daemon that never mapped leaves nothing; one that mapped saves;
    # a find asked before any map is ignored (it has nothing to search) and stops nothing.
    empty, mapped = tmp_path / "empty", tmp_path / "mapped"
    for folder in (empty, mapped):
        slam = {"map_dir": str(folder), "map_name": "shutdown", "save_on_shutdown": True}
        async with running_daemon(slam=slam) as (daemon, port):
            found = record(daemon, PoseFound)
            poses = record(daemon, PoseMeasurement)
            control = await connected(port, "control", "ui")
            await control.request(FindPoseFrame())
            if folder is mapped:
                lidar = await connected(port, "lidar", "lidar0")
                for i in range(3):
                    lidar.send(_frame(Pose2(0.05 * i, 0.0, 0.0), 10.0 + 0.1 * i))
                    await until(lambda n=i, seen=poses: len(seen) > n, timeout_s=10.0)
                await lidar.close()
            await control.close()
        assert not found  # the early find searched nothing, and tracking was not disturbed
    assert not (empty / "shutdown.yaml").exists()
    assert load_map(mapped / "shutdown.yaml").to_array().max() > 0


def _room_map(folder: Path) -> Path:
    """The test room mapped from four poses, saved as ``folder/room.yaml``."""
    from navd.geometry import scan_points
    from navd.slam.map_io import save_map
    from navd.slam.occupancy import OccupancyGrid

    grid = OccupancyGrid(0.05)
    for pose in (Pose2(0, 0, 0), Pose2(-3, -1, 1.0), Pose2(4, 2.5, -2.0), Pose2(-4, 2, 0.5)):
        a0, inc, r = cast(pose)
        grid.insert(pose, scan_points(r, a0, inc, range_min=0.1, range_max=30.0))
    return save_map(grid, folder, "room")


async def test_a_loaded_map_finds_the_robot_with_no_guess_then_near_a_given_pose(
    tmp_path: Path,
) -> None:
    path = _room_map(tmp_path)
    slam = {"load_map": str(path), "updating_map": False, "map_dir": str(tmp_path)}
    async with running_daemon(slam=slam) as (daemon, port):
        poses = record(daemon, PoseMeasurement)
        lidar = await connected(port, "lidar", "lidar0")
        control = await connected(port, "control", "ui")
        truth = Pose2(2.0, -2.5, 2.5)
        lidar.send(_frame(truth, 50.0))
        await until(lambda: bool(poses), timeout_s=15.0)
        assert math.hypot(poses[0].x_m - truth.x, poses[0].y_m - truth.y) < 0.05
        # Kidnapped: the robot is elsewhere; a person says roughly where.
        moved = Pose2(-4.5, 0.5, -1.0)
        await control.request(
            InitialPoseFrame(x=moved.x + 0.4, y=moved.y - 0.3, yaw=moved.yaw + 0.2)
        )
        lidar.send(_frame(moved, 50.1))
        await until(lambda: len(poses) > 1, timeout_s=15.0)
        assert math.hypot(poses[1].x_m - moved.x, poses[1].y_m - moved.y) < 0.05
        assert not list(tmp_path.glob("room.2.*"))  # localizing only: the map is not saved over
        await lidar.close()
        await control.close()


async def test_scan_odometry_is_rebuilt_when_its_settings_change() -> None:
    async with running_daemon(slam={"max_range_m": 20.0}, tcp=TRUSTED) as (daemon, port):
        (node,) = [m for m in daemon.manager.modules if isinstance(m, SlamNode)]
        poses = record(daemon, PoseMeasurement)
        lidar = await connected(port, "lidar", "lidar0")
        control = await connected(port, "control", "ui")
        path = [Pose2(0.05 * i, 0.0, 0.0) for i in range(8)]
        for i, truth in enumerate(path[:4]):
            lidar.send(_frame(truth, 10.0 + 0.1 * i))
            await until(lambda n=i: len(poses) > n, timeout_s=10.0)
        first = node._scan_odometry  # no wheel odometry: scan odometry is the motion prior
        assert first is not None and first.settings.voxel_size_m == 0.1
        await control.request(ConfigFrame(changes={"slam.voxel_size_m": 0.2}))
        await control.receive_type(ConfigAppliedFrame)
        await until(lambda: node._scan_odometry is not first)  # between scans, in a worker
        rebuilt = node._scan_odometry
        assert rebuilt is not first and rebuilt is not None
        assert rebuilt.settings.voxel_size_m == 0.2
        # Tracking goes on across the new odometry frame: no jump from its new origin.
        for i, truth in enumerate(path[4:], start=4):
            lidar.send(_frame(truth, 10.0 + 0.1 * i))
            await until(lambda n=i: len(poses) > n, timeout_s=10.0)
        for measured, truth in zip(poses, path, strict=True):
            assert math.hypot(measured.x_m - truth.x, measured.y_m - truth.y) < 0.05
        await lidar.close()
        await control.close()


async def test_a_settings_change_holds_when_its_worker_starts_before_the_swap() -> None:
    # The job that applies a change may run in a worker before the event loop has swapped
    # the module's settings holder (a real race, seen once in CI): here it runs at once.
    async with running_daemon(tcp=TRUSTED) as (daemon, port):
        (node,) = [m for m in daemon.manager.modules if isinstance(m, SlamNode)]
        ran: list[str] = []

        def at_once(slot: str, job: Callable[[], object]) -> None:
            ran.append(slot)
            job()

        node.ctx.submit = at_once  # type: ignore[method-assign,assignment]
        control = await connected(port, "control", "ui")
        search_xy_m = node.mapper.settings.search_xy_m * 1.25
        await control.request(ConfigFrame(changes={"slam.search_xy_m": search_xy_m}))
        await control.receive_type(ConfigAppliedFrame)
        assert ran == ["slam_settings"]
        assert node.mapper.settings.search_xy_m == search_xy_m
        assert node.settings_in_use()[0] == node.settings.value
        await control.close()


async def test_a_save_the_disk_refuses_is_answered_and_stops_nothing(tmp_path: Path) -> None:
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the map folder should be")
    slam = {"map_dir": str(blocker / "maps"), "max_range_m": 20.0}
    async with running_daemon(slam=slam) as (daemon, port):
        poses = record(daemon, PoseMeasurement)
        stops = record(daemon, SafeStop)
        lidar = await connected(port, "lidar", "lidar0")
        control = await connected(port, "control", "ui")
        lidar.send(_frame(Pose2(0, 0, 0), 10.0))
        await until(lambda: len(poses) == 1, timeout_s=10.0)
        for attempt in range(7):
            await control.request(SaveMapFrame(name=f"try{attempt}"))
            saved = await control.receive_type(MapSavedFrame)
            assert (saved.name, saved.path) == (f"try{attempt}", "")
            assert "cannot write to" in saved.reason and "not-a-folder" in saved.reason
        assert daemon.supervisor.record("slam").failures == 0
        assert daemon.supervisor.faulted() == {}
        assert stops == []
        lidar.send(_frame(Pose2(0.05, 0, 0), 10.1))  # and mapping goes on
        await until(lambda: len(poses) == 2, timeout_s=10.0)
        await lidar.close()
        await control.close()


async def test_leftovers_of_saves_cut_short_are_cleaned_at_start(tmp_path: Path) -> None:
    leftovers = [tmp_path / ".lab.3.pgm.a1b2c3d4.tmp", tmp_path / ".lab.yaml.zz99yy88.tmp"]
    for path in leftovers:
        path.write_bytes(b"half a file")
    (tmp_path / "mine.txt").write_text("not navd's")
    async with running_daemon(slam={"map_dir": str(tmp_path)}) as _:
        await until(lambda: not any(p.exists() for p in leftovers), timeout_s=10.0)
        assert (tmp_path / "mine.txt").exists()


async def test_every_save_asked_for_is_answered_even_in_a_burst(tmp_path: Path) -> None:
    async with running_daemon(slam={"map_dir": str(tmp_path), "max_range_m": 20.0}) as (
        daemon,
        port,
    ):
        poses = record(daemon, PoseMeasurement)
        lidar = await connected(port, "lidar", "lidar0")
        control = await connected(port, "control", "ui")
        lidar.send(_frame(Pose2(0, 0, 0), 10.0))
        await until(lambda: len(poses) == 1, timeout_s=10.0)
        names = [f"burst{i}" for i in range(6)]
        for name in names:  # no waiting between them: they pile up behind the first
            control.send(SaveMapFrame(name=name))
        answered = [(await control.receive_type(MapSavedFrame)) for _ in names]
        assert sorted(a.name for a in answered) == names
        assert all(a.reason == "" and (tmp_path / f"{a.name}.yaml").exists() for a in answered)
        await lidar.close()
        await control.close()


async def test_a_robot_carried_elsewhere_is_found_on_the_whole_map_when_asked(
    tmp_path: Path,
) -> None:
    path = _room_map(tmp_path)
    slam = {"load_map": str(path), "updating_map": False, "map_dir": str(tmp_path)}
    async with running_daemon(slam=slam) as (daemon, port):
        found = record(daemon, PoseFound)
        seeds = record(daemon, InitialPose)
        poses = record(daemon, PoseMeasurement)
        lidar = await connected(port, "lidar", "lidar0")
        control = await connected(port, "control", "ui")
        lidar.send(_frame(Pose2(2.0, -2.5, 2.5), 50.0))
        await until(lambda: bool(found), timeout_s=15.0)  # the loaded map's first search
        assert not seeds  # nobody asked: the estimate is not re-seeded
        carried = Pose2(-4.5, 0.5, -1.0)  # picked up and put down far away, nobody says where
        await control.request(FindPoseFrame())
        lidar.send(_frame(carried, 50.1))
        await until(lambda: len(found) > 1 and bool(seeds), timeout_s=15.0)
        assert found[1].whole_map and found[1].score > 0.5
        assert math.hypot(found[1].x_m - carried.x, found[1].y_m - carried.y) < 0.05
        assert math.hypot(seeds[0].x_m - carried.x, seeds[0].y_m - carried.y) < 0.05
        # stamped with the scan's time (the search takes a while), as is the seed
        assert found[1].stamp == seeds[0].stamp == poses[-1].stamp
        assert found[1].received >= found[1].stamp
        await lidar.close()
        await control.close()


async def test_a_robot_carried_off_is_reported_lost_held_and_found_again_without_help(
    tmp_path: Path,
) -> None:
    path = _room_map(tmp_path)
    slam = {
        "load_map": str(path),
        "updating_map": False,
        "map_dir": str(tmp_path),
        "lost_after_scans": 5,
    }
    async with running_daemon(slam=slam) as (daemon, port):
        poses = record(daemon, PoseMeasurement)
        tracking = record(daemon, TrackingLost)
        found = record(daemon, PoseFound)
        seeds = record(daemon, InitialPose)
        states = record(daemon, LocalizationState)
        stops = record(daemon, SafeStop)
        cleared = record(daemon, SafeStopCleared)
        lidar = await connected(port, "lidar", "lidar0")
        stamp = 50.0
        here = Pose2(2.0, -2.5, 2.5)
        for _ in range(30):  # found on the loaded map, and the estimate settles there
            lidar.send(_frame(here, stamp))
            stamp += 0.1
            await asyncio.sleep(0.1)
            if states and states[-1].state == "ok":
                break
        assert states[-1].state == "ok" and len(found) == 1 and not tracking
        # Picked up and put down far away and turned; nobody says so.
        carried = Pose2(-4.5, 0.5, -1.0)
        for _ in range(60):
            lidar.send(_frame(carried, stamp))
            stamp += 0.1
            await asyncio.sleep(0.1)
            if len(tracking) == 2:
                break
        lost, back = tracking
        assert lost.lost and "5 scans in a row did not fit the map" in lost.reason
        assert not back.lost and "found again" in back.reason
        # Lost: reported by localization with the reason, and the robot held until found.
        lost_states = [s for s in states if s.state == "lost"]
        assert lost_states and lost_states[0].reason == lost.reason
        assert [s.reason for s in stops] == [f"localization lost: {lost.reason}"]
        # No pose from the scans while lost; found where it is, and the estimate re-seeded.
        assert not [p for p in poses if lost.stamp <= p.stamp < back.stamp]
        for where in (found[1], seeds[0]):
            assert math.hypot(where.x_m - carried.x, where.y_m - carried.y) < 0.08
        assert found[1].stamp == seeds[0].stamp == back.stamp
        # Tracking goes on from there.
        for _ in range(5):
            lidar.send(_frame(carried, stamp))
            stamp += 0.1
            await asyncio.sleep(0.1)
        await until(lambda: poses[-1].stamp > back.stamp, timeout_s=10.0)
        assert math.hypot(poses[-1].x_m - carried.x, poses[-1].y_m - carried.y) < 0.05
        await until(lambda: states[-1].state == "ok", timeout_s=10.0)
        assert len(cleared) == 1 and cleared[0].stamp >= back.received  # and let go
        # One search found it, one seed: the module does not search again at its own seed.
        assert len(found) == 2 and len(seeds) == 1
        await lidar.close()


async def test_a_wrong_pose_given_while_lost_is_not_taken(tmp_path: Path) -> None:
    path = _room_map(tmp_path)
    slam = {"load_map": str(path), "updating_map": False, "lost_after_scans": 5}
    async with running_daemon(slam=slam) as (daemon, port):
        tracking = record(daemon, TrackingLost)
        found = record(daemon, PoseFound)
        lidar = await connected(port, "lidar", "lidar0")
        control = await connected(port, "control", "ui")
        stamp = 50.0
        lidar.send(_frame(Pose2(2.0, -2.5, 2.5), stamp))
        await until(lambda: bool(found), timeout_s=15.0)  # found on the loaded map
        carried = Pose2(-4.5, 0.5, -1.0)
        for _ in range(5):  # lost after five scans from somewhere else
            stamp += 0.1
            lidar.send(_frame(carried, stamp))
            await asyncio.sleep(0.1)
        await until(lambda: bool(tracking), timeout_s=10.0)
        assert tracking[0].lost and len(tracking) == 1
        # A person means well but is wrong: 4 m off, facing the other way. What a search
        # there finds does not fit; the robot stays lost and searches on from there.
        await control.request(InitialPoseFrame(x=0.0, y=2.5, yaw=2.0))
        for _ in range(40):
            stamp += 0.1
            lidar.send(_frame(carried, stamp))
            await asyncio.sleep(0.1)
            if len(tracking) == 2:
                break
        assert not tracking[1].lost and "found again" in tracking[1].reason
        for where in found[1:]:  # nothing was taken but the truth
            assert math.hypot(where.x_m - carried.x, where.y_m - carried.y) < 0.08
        await lidar.close()
        await control.close()


async def test_a_map_loaded_at_run_time_searches_for_the_robot_and_restarts_the_estimate(
    tmp_path: Path,
) -> None:
    from navd.wire import LoadMapFrame

    _room_map(tmp_path)
    async with running_daemon(slam={"map_dir": str(tmp_path), "updating_map": False}) as (
        daemon,
        port,
    ):
        found = record(daemon, PoseFound)
        seeds = record(daemon, InitialPose)
        control = await connected(port, "control", "ui")
        lidar = await connected(port, "lidar", "lidar0")
        await control.request(LoadMapFrame(name="room"))
        await asyncio.sleep(0.5)  # loaded in a worker
        robot = Pose2(-4.5, 0.5, -1.0)
        lidar.send(_frame(robot, 50.0))
        await until(lambda: bool(found) and bool(seeds), timeout_s=15.0)
        assert found[0].whole_map
        assert math.hypot(found[0].x_m - robot.x, found[0].y_m - robot.y) < 0.05
        assert math.hypot(seeds[0].x_m - robot.x, seeds[0].y_m - robot.y) < 0.05
        await lidar.close()
        await control.close()
