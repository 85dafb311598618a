"""``navd demo``: the daemon and the simulator together, a goal, and a picture of the drive.

The daemon runs as its own process (``python -m navd run``) on a config written for the
demo: the chassis driver on the simulator's pseudo-terminal with encoder feedback, the TCP
server on a free port. The simulator runs in this process and connects its lidar and IMU like
external sensor programs; a control client sends the start pose and the goal, follows the
status and the planned route, asks for the map when the drive is over, and the results go to
``demo.png`` and ``summary.json``.

With ``view`` the drive runs in real time with the operator page served on a free port: its
address is printed (and opened in a browser where there is one), the goal waits a moment so
the page shows the start, and after the drive the robot stays up for goals from the page
until Ctrl-C.

Ctrl-C or SIGTERM during the drive ends it as a timeout would: the goal is canceled, the map
saved, the picture and summary written (``canceled``, "the demo was ended") and the daemon
stopped; nothing is left running.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import signal
import sys
import tempfile
import webbrowser
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navd.sim.errors import SimError
from navd.sim.picture import demo_picture
from navd.sim.ports import free_port, port_taken
from navd.sim.runner import Simulator
from navd.sim.sim_session import Session, session
from navd.sim.world import World
from navd.wire import (
    CancelFrame,
    ClientError,
    ConnectionClosedError,
    GoalFrame,
    GoalStatusFrame,
    InitialPoseFrame,
    PathFrame,
    Reply,
    SaveMapFrame,
    StatusFrame,
    SubscribeFrame,
)

__all__ = ["DemoResult", "run_demo"]

VIEW_WARM_UP_S = 3.0  # [s] the page loads and shows the start before the goal goes out


@dataclass
class DemoResult:
    """What a demo drive recorded."""

    state: str = "timeout"
    reason: str = ""
    time_s: float = math.nan
    chassis_lines: int = 0  # wheel lines the chassis received by the drive's end
    routes: list[list[list[float]]] = field(default_factory=list)  # every route, in order
    estimated: list[tuple[float, float, float]] = field(default_factory=list)


async def _drive(
    s: Session, world: World, limit_s: float, progress: bool, stop: asyncio.Event | None = None
) -> DemoResult:
    """Send the start pose and the goal; follow status until arrival, failure, timeout or
    ``stop``."""
    assert world.goal is not None
    control, sim = s.control, s.sim
    result = DemoResult()
    # The start as the initial pose: SLAM starts its map there, so map and world coincide.
    x0, y0, yaw0 = world.start
    control.send(InitialPoseFrame(x=x0, y=y0, yaw=yaw0, std_xy=0.02))
    control.send(SubscribeFrame(rate_hz=5))
    gx, gy, gyaw = world.goal
    try:
        await control.request(GoalFrame(x=gx, y=gy, yaw=gyaw, goal_id="demo"))
    except (ClientError, TimeoutError) as err:
        raise SimError(f"navd did not take the demo's goal: {err}") from err
    sim.release_clock()  # on simulated time, the drive starts at 0 s with the goal known
    started = sim.now()
    shown_at = -math.inf
    try:
        while sim.now() - started < limit_s:
            if stop is not None and stop.is_set():
                result.state, result.reason = "canceled", "the demo was ended"
                control.send(CancelFrame())
                break
            s.check()
            try:
                frame = await control.receive(1.0)
            except TimeoutError:
                continue
            except ConnectionClosedError:
                result.reason = "navd closed the connection"
                break
            if isinstance(frame, StatusFrame) and frame.pose is not None and progress:
                shown_at = _progress(frame, sim.now() - started, shown_at)
            if _record(frame, result):
                break
        result.time_s = sim.now() - started
        # Counted here: the simulation runs on while the map is saved, for however long that
        # takes on this machine, and the wheels get a line each control tick meanwhile.
        result.chassis_lines = sim.chassis_lines
        if result.state == "timeout":
            result.reason = f"not there after {limit_s:.0f} s"
            control.send(CancelFrame())
        control.send(SaveMapFrame(name="demo"))
        await asyncio.sleep(1.0)  # the map is saved in a worker
    finally:
        if progress and sys.stderr.isatty():
            print(file=sys.stderr)  # end the line rewritten in place
    return result


def _record(frame: Reply, result: DemoResult) -> bool:
    """Keep what ``frame`` says about the demo's drive; True once its goal is over."""
    if isinstance(frame, PathFrame) and frame.goal_id == "demo":
        result.routes.append([list(p) for p in frame.points])
    elif isinstance(frame, StatusFrame) and frame.pose is not None:
        result.estimated.append((frame.pose.x, frame.pose.y, frame.pose.yaw))
    elif (
        isinstance(frame, GoalStatusFrame)
        and frame.goal_id == "demo"
        and frame.state in ("reached", "failed", "canceled")
    ):
        result.state = frame.state
        result.reason = frame.reason
        return True
    return False


def _progress(frame: StatusFrame, elapsed_s: float, shown_at: float) -> float:
    """A progress line: rewritten in place on a terminal, every 5 s otherwise."""
    terminal = sys.stderr.isatty()
    if not terminal and elapsed_s - shown_at < 5.0:
        return shown_at
    remaining = frame.goal.distance_remaining if frame.goal is not None else None
    left = f"{remaining:5.1f} m to go" if remaining is not None else "planning"
    safety = ", ".join(frame.diagnostics.safety) or "ok"
    text = f"demo: {elapsed_s:5.1f} s  {frame.mode:<10} {left}  safety: {safety}"
    print(f"\r{text:<78}" if terminal else text, end="" if terminal else "\n", file=sys.stderr)
    sys.stderr.flush()
    return elapsed_s


def run_demo(
    world: World,
    out: Path,
    *,
    limit_s: float = 180.0,
    progress: bool = True,
    lockstep: bool = True,
    view: bool = False,
    view_port: int = 0,
    page_port: int = 0,
    record: Path | None = None,
) -> dict[str, Any]:
    """Run the demo in ``world`` and write ``demo.png`` and ``summary.json`` into ``out``.

    ``lockstep`` runs on simulated time, deterministic and as fast as the CPU allows;
    False runs in real time (to watch the robot live through a control client). ``view``
    serves the operator page and runs in real time (see the module docstring): the live
    view's WebSocket on ``view_port`` and the page on ``page_port`` (0: a free one), both on
    127.0.0.1, so an SSH tunnel can name them. ``record`` has the daemon record the drive to
    MCAP files there (``navd replay`` plays them back).

    Returns:
        The summary.

    Raises:
        SimError: the world has no goal, a chosen port is taken, or navd could not be
            started or reached.
    """
    if world.goal is None:
        raise SimError(f"world {world.name!r} has no goal: add goal = [x, y, yaw]")
    if view:
        view_port, page_port = _view_ports(view_port, page_port)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="navd-demo-") as tmp:
        work = Path(tmp)

        overrides: dict[str, Any] = {}
        if view:
            overrides["viz"] = {"port": view_port, "page_port": page_port}
        if record is not None:
            overrides["record"] = {"enabled": True, "dir": str(record.resolve())}

        async def main() -> tuple[DemoResult, Simulator]:
            async with session(
                world,
                work,
                overrides=overrides,
                log_path=out / "demo.log",
                lockstep=lockstep and not view,
                hold_clock=True,
            ) as s:
                # Ctrl-C or SIGTERM (a timeout, systemd, kill) ends the drive: the goal is
                # canceled, the map saved and the results written, and the daemon stopped.
                with _ended_by_signals() as ended:
                    if view:
                        await _open_page(page_port, view_port)
                    result = await _drive(s, world, limit_s, progress, ended)
                    if view:
                        await _stay_up(s, ended)
                return result, s.sim

        if progress:
            first = " (its first run here compiles its kernels: about 40 s)" if _cold() else ""
            print(f"navd demo: starting navd{first}", file=sys.stderr, flush=True)
        result, sim = asyncio.run(main())
        built = _load_built_map(work / "maps" / "demo.yaml")
    truth = np.array([(x, y, yaw) for _, x, y, yaw in sim.truth]).reshape(-1, 3)
    summary = _summary(world, sim, result, truth)
    demo_picture(world, built, result.routes, result.estimated, truth, out / "demo.png")
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return summary


def _view_ports(view_port: int, page_port: int) -> tuple[int, int]:
    """The live view's and the page's ports: the chosen ones, checked free now (a taken one
    is named before navd starts), else free ones."""
    if view_port and view_port == page_port:
        raise SimError(f"--port and --page-port are both {view_port}: give each its own")
    for port, option in ((view_port, "--port"), (page_port, "--page-port")):
        if port and (why := port_taken(port)) is not None:
            raise SimError(
                f"{option} {port} cannot be used on 127.0.0.1 ({why}): choose another, or "
                "leave the option out for a free one"
            )
    while not view_port or view_port == page_port:  # a free one, never the page's chosen one
        view_port = free_port()
    while not page_port or page_port == view_port:
        page_port = free_port()
    return view_port, page_port


async def _open_page(page_port: int, view_port: int) -> None:
    """Say where the page and the live view are, open the page where a browser can, and
    give it time to load."""
    url = f"http://127.0.0.1:{page_port}/"
    print(f"navd demo: the operator page is at {url}", file=sys.stderr, flush=True)
    print(
        f"navd demo: the live view is at ws://127.0.0.1:{view_port} (Foxglove: Open "
        "connection, Foxglove WebSocket)",
        file=sys.stderr,
        flush=True,
    )
    opened = await asyncio.to_thread(webbrowser.open, url)
    if not opened:
        print("navd demo: no browser here; open the address above in one", file=sys.stderr)
    await asyncio.sleep(VIEW_WARM_UP_S)


@contextlib.contextmanager
def _ended_by_signals() -> Iterator[asyncio.Event]:
    """An event Ctrl-C (or SIGTERM) sets instead of interrupting, while inside; the handlers
    of before afterwards (the loop's removal would leave SIGTERM at the default, which ends
    the process on the spot while the demo draws its picture)."""
    ended = asyncio.Event()
    loop = asyncio.get_running_loop()
    signals = (signal.SIGINT, signal.SIGTERM)
    before = {sig: signal.getsignal(sig) for sig in signals}
    for sig in signals:
        loop.add_signal_handler(sig, ended.set)
    try:
        yield ended
    finally:
        for sig in signals:
            loop.remove_signal_handler(sig)
            if before[sig] is not None:  # None: set outside Python, nothing to put back
                signal.signal(sig, before[sig])


async def _stay_up(s: Session, ended: asyncio.Event) -> None:
    """After the drive, keep the robot up for goals from the page until ``ended``."""
    if ended.is_set():
        return
    print(
        "navd demo: the robot waits for goals from the page (tap the map; drag for the pose; "
        "the joystick drives); Ctrl-C ends the demo",
        file=sys.stderr,
        flush=True,
    )
    while not ended.is_set():
        s.check()
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(ended.wait(), 1.0)


def _cold() -> bool:
    """Whether the daemon will compile kernels before it drives (not knowing counts as yes)."""
    from navd.kernels import KernelCacheError, cold_kernels  # noqa: PLC0415 - loads every kernel module

    try:
        return bool(cold_kernels())
    except KernelCacheError:
        return True


def _load_built_map(path: Path) -> Any:
    from navd.slam import (  # noqa: PLC0415
        MapFileError,
        load_map,
    )

    try:
        return load_map(path)
    except MapFileError:
        return None


def _summary(world: World, sim: Simulator, result: DemoResult, truth: np.ndarray) -> dict[str, Any]:
    """The numbers a person wants after a drive."""
    driven = float(np.hypot(*np.diff(truth[:, :2], axis=0).T).sum()) if len(truth) > 1 else 0.0
    assert world.goal is not None
    end = truth[-1] if len(truth) else np.array(world.start)
    pose_error = math.nan
    if result.estimated and len(truth):
        ex, ey, _ = result.estimated[-1]
        pose_error = math.hypot(ex - end[0], ey - end[1])
    route = np.array(result.routes[0] if result.routes else []).reshape(-1, 2)
    return {
        "world": world.name,
        "reached": result.state == "reached",
        "state": result.state,
        "reason": result.reason,
        "time_s": round(result.time_s, 2),
        "driven_length_m": round(driven, 3),
        "first_route_length_m": round(float(np.hypot(*np.diff(route, axis=0).T).sum()), 3)
        if len(route) > 1
        else None,
        "routes_planned": len(result.routes),
        "final_distance_to_goal_m": round(
            math.hypot(end[0] - world.goal[0], end[1] - world.goal[1]), 3
        ),
        "min_clearance_m": round(sim.body.min_clearance_m, 3),
        "collisions": sim.body.collisions,
        "final_pose_error_m": round(pose_error, 3) if math.isfinite(pose_error) else None,
        "chassis_lines": result.chassis_lines,
    }
