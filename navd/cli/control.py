"""``navd goal|cancel|estop|status``: a control client of the running daemon."""

from __future__ import annotations

import argparse
import math
import sys
import time

from pydantic import ValidationError

from navd.cli.common import (
    EXIT_CANCELED,
    EXIT_FAILED,
    EXIT_OK,
    EXIT_USAGE,
    Commands,
    connect,
    connection_options,
)
from navd.config import ConfigError
from navd.wire import (
    CancelFrame,
    Client,
    ClientError,
    EmergencyStopFrame,
    GoalFrame,
    GoalStatusFrame,
    RecordFrame,
    StatusFrame,
    SubscribeFrame,
    frame_text,
)

__all__ = ["add_commands", "format_status", "goal_line"]

GOAL_VERDICT_S = 2.0  # [s] how long ``navd goal`` waits to hear whether the goal was taken
PROGRESS_PERIOD_S = 5.0  # [s] ``navd goal --wait`` writes a progress line this often to a file
GOAL_ENDS = ("reached", "failed", "canceled")  # a goal's last states
HELD_CHECK_HZ = 2.0  # [Hz] status frames ``navd goal --wait`` reads for safety's holds
RECORD_VERDICT_STATUSES = 10  # status frames ``navd record start`` reads for the outcome (1 s)


def add_commands(commands: Commands) -> None:
    """Add ``goal``, ``cancel``, ``estop``, ``record`` and ``status``."""
    goal = commands.add_parser(
        "goal",
        help="send a goal in the map frame (exit 1 with the reason if navd refuses it at once)",
    )
    goal.add_argument("x", type=float, help="[m] map x")
    goal.add_argument("y", type=float, help="[m] map y")
    goal.add_argument("--yaw", type=float, help="[rad] final heading (default: any)")
    goal.add_argument("--id", dest="goal_id", help="goal id (default: chosen by navd)")
    goal.add_argument(
        "--wait",
        action="store_true",
        help="follow the goal to its end with a progress line; exit 0 reached, 1 failed, "
        "3 canceled",
    )
    goal.add_argument("--json", action="store_true", help="print navd's answers as raw JSON frames")
    connection_options(goal)
    goal.set_defaults(handler=_goal)

    cancel = commands.add_parser("cancel", help="cancel the active goal")
    cancel.add_argument("--id", dest="goal_id", help="cancel only this goal")
    cancel.add_argument("--json", action="store_true", help="print navd's answer as raw JSON")
    connection_options(cancel)
    cancel.set_defaults(handler=_cancel)

    estop = commands.add_parser(
        "estop", help="emergency stop: the robot stops at once and stays still until released"
    )
    estop.add_argument("--release", action="store_true", help="release the emergency stop")
    connection_options(estop)
    estop.set_defaults(handler=_estop)

    record = commands.add_parser(
        "record", help="start or stop recording the session (to record.dir, as MCAP files)"
    )
    record.add_argument("action", choices=("start", "stop"))
    connection_options(record)
    record.set_defaults(handler=_record)

    status = commands.add_parser("status", help="watch the daemon's status")
    status.add_argument("--rate", type=float, default=2.0, help="[Hz] updates per second")
    status.add_argument("--once", action="store_true", help="print one status and exit")
    status.add_argument("--json", action="store_true", help="print raw status frames")
    connection_options(status)
    status.set_defaults(handler=_status)


def goal_line(status: GoalStatusFrame) -> str:
    """One readable line for a goal's progress: its state, what is left, and why."""
    ended = status.state in GOAL_ENDS
    left = None if ended else status.distance_remaining
    eta = None if ended else status.eta_s
    return (
        f"{status.goal_id}: {status.state}"
        + (f", {left:.1f} m to go" if left is not None else "")
        + (f", {eta:.0f} s" if eta is not None else "")
        + (f" ({status.reason})" if status.reason else "")
    )


def _goal(args: argparse.Namespace) -> int:
    try:
        frame = GoalFrame(x=args.x, y=args.y, yaw=args.yaw, goal_id=args.goal_id)
    except ValidationError as err:
        problem = err.errors()[0]
        where = ".".join(str(p) for p in problem["loc"]) or "goal"
        print(f"navd goal: {where}: {problem['msg']}", file=sys.stderr)
        return EXIT_USAGE
    verdict: GoalStatusFrame | None
    try:
        with connect(args) as client:
            if args.wait:  # safety's reasons come in status frames; asked before the goal,
                # as frames that come while a request waits for its answer are passed over
                client.request(SubscribeFrame(rate_hz=HELD_CHECK_HZ))
            ack = client.request(frame)
            heading = "" if frame.yaw is None else f", heading {frame.yaw:.2f} rad"
            print(
                frame_text(ack)
                if args.json
                else f"goal {ack.goal_id} sent: ({frame.x:.2f}, {frame.y:.2f}) m{heading}",
                flush=True,
            )
            if args.wait:
                verdict = _follow(client, ack.goal_id)
                print(frame_text(verdict) if args.json else goal_line(verdict))
            else:
                verdict = _first_status(client, ack.goal_id)
                if verdict is not None and not args.json and verdict.state != "failed":
                    print(goal_line(verdict))
    except (ClientError, ConfigError) as err:
        print(f"navd goal: {err}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        print("\nnavd goal: stopped following; the goal goes on", file=sys.stderr)
        return EXIT_FAILED
    if verdict is not None and verdict.state == "failed":
        print(f"navd goal: {verdict.goal_id} failed: {verdict.reason}", file=sys.stderr)
        return EXIT_FAILED
    if verdict is not None and verdict.state == "canceled":
        print(f"navd goal: {verdict.goal_id} canceled: {verdict.reason}", file=sys.stderr)
        return EXIT_CANCELED
    return EXIT_OK


def _follow(client: Client, goal_id: str | None) -> GoalStatusFrame:
    """Follow the goal to its end, showing its progress (rewritten in place on a terminal,
    a line every PROGRESS_PERIOD_S otherwise) and, at once, whenever safety starts or stops
    holding the robot and why (from the status frames subscribed to); its last status."""
    client.timeout_s = None  # a long drive: wait as long as it takes
    client.sock.settimeout(None)
    terminal = sys.stderr.isatty()
    shown_at = -math.inf
    held: tuple[str, ...] = ()
    last: GoalStatusFrame | None = None
    while True:
        reply = client.receive()
        if isinstance(reply, StatusFrame):
            if tuple(reply.diagnostics.safety) == held:
                continue
            held = tuple(reply.diagnostics.safety)
            if last is None:
                continue
            status, now = last, math.inf  # a change of hold is shown at once
        elif isinstance(reply, GoalStatusFrame) and reply.goal_id == goal_id:
            status = last = reply
            if status.state in GOAL_ENDS:
                if terminal:
                    print(file=sys.stderr)
                return status
            now = time.monotonic()
        else:
            continue
        if terminal or now - shown_at >= PROGRESS_PERIOD_S:
            shown_at = time.monotonic()
            line = goal_line(status) + (f" - held by safety: {'; '.join(held)}" if held else "")
            print(
                f"\r\x1b[K{line}" if terminal else line,  # the line before cleared
                end="" if terminal else "\n",
                file=sys.stderr,
                flush=True,
            )


def _first_status(client: Client, goal_id: str | None) -> GoalStatusFrame | None:
    """The goal's first progress report within GOAL_VERDICT_S, or None (none came yet)."""
    client.timeout_s = GOAL_VERDICT_S
    client.sock.settimeout(GOAL_VERDICT_S)
    try:
        while True:
            status = client.receive_type(GoalStatusFrame)
            if status.goal_id == goal_id:
                return status
    except ClientError:
        return None


def _estop(args: argparse.Namespace) -> int:
    try:
        with connect(args) as client:
            client.request(EmergencyStopFrame(engaged=not args.release))
    except (ClientError, ConfigError) as err:
        print(f"navd estop: {err}", file=sys.stderr)
        return EXIT_FAILED
    print("emergency stop released" if args.release else "emergency stop engaged")
    return EXIT_OK


def _cancel(args: argparse.Namespace) -> int:
    try:
        with connect(args) as client:
            ack = client.request(CancelFrame(goal_id=args.goal_id))
    except (ClientError, ConfigError) as err:
        print(f"navd cancel: {err}", file=sys.stderr)
        return EXIT_FAILED
    if args.json:
        print(frame_text(ack))
    else:  # the daemon stops the goal if one is active (navd status shows it)
        print("cancel accepted" if args.goal_id is None else f"cancel of {args.goal_id} accepted")
    return EXIT_OK


def _record(args: argparse.Namespace) -> int:
    """Ask for a recording to start or stop; then say what the daemon reports (the file it
    writes, or the one it closed)."""
    starting = args.action == "start"
    try:
        with connect(args) as client:
            client.request(SubscribeFrame(rate_hz=10))
            before = client.receive_type(StatusFrame).recording
            client.request(RecordFrame(action=args.action))
            for _ in range(_record_statuses(starting)):
                frame = client.receive_type(StatusFrame)
                if (frame.recording is not None) == starting:
                    break
    except (ClientError, ConfigError) as err:
        print(f"navd record: {err}", file=sys.stderr)
        return EXIT_FAILED
    if starting and frame.recording is None:
        print("navd record: not recording; the daemon's log says why", file=sys.stderr)
        return EXIT_FAILED
    if starting:
        print(
            f"recording to {frame.recording}"
            if before is None
            else f"already recording to {frame.recording}"
        )
    elif frame.recording is not None:
        print(
            f"navd record: still recording to {frame.recording} after the stop and the time "
            "to close it; the daemon's log says why",
            file=sys.stderr,
        )
        return EXIT_FAILED
    else:
        print("was not recording" if before is None else f"recording stopped: {before}")
    return EXIT_OK


def _record_statuses(starting: bool) -> int:
    """Status frames (10 a second) to read for a record request's outcome: a stop waits
    for the file to be closed, which the recorder gives its writer CLOSE_TIMEOUT_S for (a
    long recording on a slow card)."""
    if starting:
        return RECORD_VERDICT_STATUSES
    from navd.viz import CLOSE_TIMEOUT_S  # noqa: PLC0415 - stop only

    return RECORD_VERDICT_STATUSES + math.ceil(10 * CLOSE_TIMEOUT_S)


def _status(args: argparse.Namespace) -> int:
    try:
        with connect(args) as client:
            client.request(SubscribeFrame(rate_hz=args.rate))
            while True:
                frame = client.receive_type(StatusFrame)
                print(frame_text(frame) if args.json else format_status(frame), flush=True)
                if args.once:
                    return EXIT_OK
    except (ClientError, ConfigError) as err:
        print(f"navd status: {err}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        return EXIT_OK


def format_status(frame: StatusFrame) -> str:
    """One readable line for a status frame."""
    pose = frame.pose
    where = (
        f"pose ({pose.x:.2f}, {pose.y:.2f}) m {math.degrees(pose.yaw):.0f} deg"
        if pose
        else "pose unknown"
    )
    vel = frame.velocity
    moving = f"v {vel.linear:.2f} m/s w {vel.angular:.2f} rad/s" if vel else "v -"
    goal = frame.goal
    target = f"goal {goal.goal_id} {goal.state}" if goal else "no goal"
    devices = (
        ", ".join(f"{d.device_id}({d.kind}{', STALE' if d.stale else ''})" for d in frame.devices)
        or "none"
    )
    diag = frame.diagnostics
    lag = diag.loop_lag_p99_ms
    safety = "; ".join(diag.safety) or "ok"
    lag_text = f"{lag:.2f} ms" if lag is not None else "-"
    mode = f"manual: {frame.operator}" if frame.operator else frame.mode
    if frame.recording:
        mode += ", recording"
    return (
        f"{frame.robot} [{mode}] {where} | {moving} | {target} | {_battery_text(frame)}"
        f"devices: {devices} | lag p99 {lag_text} | safety: {safety}"
    )


def _battery_text(frame: StatusFrame) -> str:
    """ "battery 76% 12.1 V charging (low) | ", or "" without a battery sensor."""
    battery = frame.battery
    if battery is None:
        return ""
    parts = ["battery"]
    if battery.percentage is not None:
        parts.append(f"{battery.percentage * 100:.0f}%")
    parts.append(f"{battery.voltage:.1f} V")
    if battery.charging:
        parts.append("charging")
    if battery.alarm != "ok":
        parts.append(f"({battery.alarm})")
    return " ".join(parts) + " | "
