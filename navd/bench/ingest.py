"""Ingest benchmark: the real daemon under full sensor load from separate client processes.

IMU at 1 kHz, lidar at 10 Hz with 1440 rays, GPS at 5 Hz and compass at 10 Hz stream for a
few seconds, twice: into a daemon with only its ingest path (TCP server and safety gate:
sockets, framing, decoding, stamping, publishing), then into the whole daemon (which also
fuses the IMU, matches every scan and, one second in, is given a goal 1 m ahead that it
plans and drives toward for the rest of the run: DWA at its control rate). Printed for
each: CPU use over the streaming window (% of one core, from the kernel's scheduler
statistics), event-loop lag p50/p99/max over the same window (from its status), messages
dropped (sent by the clients minus accepted by the daemon), resident memory at the end and
at its peak (``/proc/PID/status``), seconds from launch to accepting connections (the numba
cache is warm: the benchmark's earlier runs filled it), and the goal's state at the end
(``active``: still being driven). The idle CPU (lag probe, status and staleness timers),
measured once start-up work is over, is reported beside the total; the ingest figure is the
difference.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navd.sim import free_port
from navd.wire import Client, GoalFrame, StatusFrame, SubscribeFrame

STREAMS = (("imu", 1000.0), ("lidar", 10.0), ("gps", 5.0), ("compass", 10.0))
LAG_PROBE_S = 0.05  # the daemon's default probe period
IDLE_S = 3.0  # [s] idle measurement before streaming: the daemon's own baseline
GOAL_AFTER_S = 1.0  # [s] streaming before the whole daemon gets its goal
SETTLED_PERCENT = 5.0  # [% of a core] below this, start-up work is taken to be over
SENSOR_PROGRAM = (sys.executable, "-m", "navd", "sensor", "ld06", "--log-level", "warning")


@dataclass(frozen=True)
class _Cpu:
    """CPU time used so far by a process: per live thread to the nanosecond (the kernel's
    scheduler statistics), and in total in 10 ms ticks (``/proc/PID/stat``, which also keeps
    the time of threads that have ended)."""

    threads: dict[int, float]  # [s] per thread id
    ticks_s: float

    @classmethod
    def read(cls, pid: int) -> _Cpu:
        threads = {}
        for task in Path(f"/proc/{pid}/task").iterdir():
            with contextlib.suppress(FileNotFoundError, ProcessLookupError):  # a thread ended
                threads[int(task.name)] = int((task / "schedstat").read_text().split()[0]) / 1e9
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return cls(threads, (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK"))

    def percent_since(self, before: _Cpu, wall_s: float) -> float:
        """[% of one core] used between ``before`` and this reading, ``wall_s`` [s] apart:
        to the nanosecond, unless a thread ended in between (then to the tick)."""
        ticks = self.ticks_s - before.ticks_s
        precise = sum(t - before.threads.get(tid, 0.0) for tid, t in self.threads.items())
        tick_s = 1.0 / os.sysconf("SC_CLK_TCK")
        whole = before.threads.keys() <= self.threads.keys() and abs(precise - ticks) <= 2 * tick_s
        return 100.0 * (precise if whole else ticks) / wall_s


def _rss_mb(pid: int) -> tuple[float, float]:
    """[MB] the process's resident memory now and at its peak (``/proc/PID/status``)."""
    fields = dict(
        line.split(":", 1) for line in Path(f"/proc/{pid}/status").read_text().splitlines()
    )
    return (int(fields["VmRSS"].split()[0]) / 1024, int(fields["VmHWM"].split()[0]) / 1024)


def _send_goal(port: int) -> None:
    """A goal 1 m ahead of where the benchmark's lidar stands: driven (the robot never
    reaches it, as the scans stay the same) for the rest of the streaming."""
    with Client("127.0.0.1", port, device_id="bench-goal") as control:
        control.send(GoalFrame(x=1.0, y=0.0, goal_id="bench"))


def _status(port: int) -> StatusFrame:
    with Client("127.0.0.1", port, device_id="bench-probe") as control:
        control.request(SubscribeFrame(rate_hz=10))
        return control.receive_type(StatusFrame)


def run(
    *,
    seconds: float = 10.0,
    rays: int = 1440,
    binary: bool = False,
    imu_batch: int = 1,
    view: bool = False,
    lidar_program: int = 0,
) -> dict[str, Any]:
    """Run the benchmark on the ingest path alone, then on the whole daemon; their figures.
    With ``view``, the whole daemon twice more: with the live view off, and with a viewer
    subscribed to every channel (in its own process); and what the view costs. With
    ``lidar_program`` (points per turn), the lidar is an emulated LD06 on a pseudo-terminal
    read by ``navd sensor ld06``, whose own CPU use is reported too."""
    load = (seconds, rays, binary, imu_batch, lidar_program)
    ingest = _measure("navd.bench.ingest_daemon", *load)
    whole = _measure("navd", *load)
    figures = {
        "seconds": ingest["seconds"],
        "lidar_rays": rays,
        "lidar_encoding": "base64 float32" if binary else "json",
        **(
            {"lidar_program": f"navd sensor ld06, {lidar_program} points per turn"}
            if lidar_program
            else {}
        ),
        "imu_lines_per_write": imu_batch,
        "ingest_path": ingest["figures"],
        "whole_daemon": whole["figures"],
    }
    if view:
        off = _measure("navd", *load, view="off")["figures"]
        watched = _measure("navd", *load, view="watched")["figures"]
        cpu = "cpu_percent_of_one_core"
        figures |= {
            "whole_daemon_view_off": off,
            "whole_daemon_watched": watched,
            "view_unwatched_cpu_points": round(whole["figures"][cpu] - off[cpu], 2),
            "view_watched_cpu_points": round(watched[cpu] - off[cpu], 2),
        }
    return figures


def _measure(  # noqa: PLR0917 - the load's parameters, as ``run`` takes them
    module: str,
    seconds: float,
    rays: int,
    binary: bool,
    imu_batch: int,
    lidar_program: int,
    view: str = "unwatched",
) -> dict[str, Any]:
    """Stream at full load into the daemon started by ``python -m <module>``; its figures.
    ``view``: the live view "unwatched" (on, as by default), "off", or "watched" by a viewer
    subscribed to every channel."""
    port = free_port()
    view_port = free_port()
    window = int(seconds / LAG_PROBE_S)
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "navd.toml"
        _write_config(config, port, view_port, window, view)
        command = [sys.executable, "-m", module]
        launched = time.monotonic()
        daemon = subprocess.Popen(
            [*command, *(["run"] if module == "navd" else []), "--config", str(config)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        clients: list[subprocess.Popen[str]] = []
        viewer: subprocess.Popen[str] | None = None
        program: subprocess.Popen[bytes] | None = None
        try:
            _wait_listening(port, daemon)
            ready_s = time.monotonic() - launched
            _wait_settled(daemon.pid)  # start-up work (imports, kernel warm-ups) is over
            idle_percent = _idle_percent(daemon.pid)
            viewer = _start_viewer(view_port) if view == "watched" else None
            clients = _start_clients(port, seconds, rays, binary, imu_batch, lidar_program)
            said = [_ready(client) for client in clients]  # all connected: measure from here
            if lidar_program:
                program = _start_lidar_program(port, said[1]["tty"])
            cpu_start, wall_start = _Cpu.read(daemon.pid), time.monotonic()
            program_start = None if program is None else _Cpu.read(program.pid)
            _say(clients, "go")
            if module == "navd":
                time.sleep(GOAL_AFTER_S)  # a map and a pose to plan on
                _send_goal(port)
            sent = {
                role: _ready(client)["sent"]
                for (role, _), client in zip(STREAMS, clients, strict=True)
            }
            cpu_end, wall_end = _Cpu.read(daemon.pid), time.monotonic()
            program_percent = _percent_since(program, program_start, wall_end - wall_start)
            status = _status(port)
            rss_mb, peak_rss_mb = _rss_mb(daemon.pid)
            viewed = None if viewer is None else _stop_viewer(viewer)
        finally:
            _stop_all(daemon, clients, viewer, program)
    accepted = {d.kind: d.accepted for d in status.devices}
    total_percent = cpu_end.percent_since(cpu_start, wall_end - wall_start)
    diag = status.diagnostics
    return {
        "seconds": round(wall_end - wall_start, 2),
        "figures": {
            "cpu_percent_of_one_core": round(total_percent, 2),
            "idle_cpu_percent_of_one_core": round(idle_percent, 2),
            "ingest_cpu_percent_of_one_core": round(total_percent - idle_percent, 2),
            "loop_lag_p50_ms": diag.loop_lag_p50_ms,
            "loop_lag_p99_ms": diag.loop_lag_p99_ms,
            "loop_lag_max_ms": diag.loop_lag_max_ms,
            "messages": {
                role: {"sent": sent[role], "accepted": accepted.get(role, 0)} for role, _ in STREAMS
            },
            "dropped": sum(sent[role] - accepted.get(role, 0) for role, _ in STREAMS),
            "rss_mb": round(rss_mb, 1),
            "peak_rss_mb": round(peak_rss_mb, 1),
            "ready_s": round(ready_s, 3),
            "goal": None if status.goal is None else status.goal.state,
            **(
                {}
                if program_percent is None
                else {"sensor_program_cpu_percent_of_one_core": round(program_percent, 2)}
            ),
            **({} if viewed is None else {"viewer_received": viewed}),
        },
    }


def _write_config(path: Path, port: int, view_port: int, window: int, view: str) -> None:
    """The defaults, but for staleness timeouts long enough for the clients to start one by
    one, a lag window that covers the streaming exactly, and the live view (on, nobody
    watching) on a free port. (The status goes out at its default 1 Hz: a viewer subscribed
    at 10 Hz costs about half a percent more.)"""
    path.write_text(
        f"[tcp]\nport = {port}\nimu_timeout_s = 5.0\nlidar_timeout_s = 5.0\n"
        f"[lifecycle]\nlag_sample_period_s = {LAG_PROBE_S}\nlag_window = {window}\n"
        '[logging]\nlevel = "warning"\n'
        + (
            "[viz]\nenabled = false\n"
            if view == "off"
            else f"[viz]\nport = {view_port}\npage_port = 0\n"
        )
    )


def _start_clients(  # noqa: PLR0917 - the load's parameters
    port: int, seconds: float, rays: int, binary: bool, imu_batch: int, lidar_program: int
) -> list[subprocess.Popen[str]]:
    """One sensor client process per stream, each waiting for "go" on its standard input;
    with ``lidar_program``, the lidar's is an emulated LD06 instead."""
    clients: list[subprocess.Popen[str]] = []
    for role, rate in STREAMS:
        if role == "lidar" and lidar_program:
            device = [sys.executable, "-m", "navd.sim.devices.process", "ld06"]
            device += ["--seconds", str(seconds), "--points", str(lidar_program)]
            clients.append(
                subprocess.Popen(device, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
            )
            continue
        command = [
            sys.executable,
            "-m",
            "navd.bench.sensor_client",
            "--role",
            role,
            "--rate",
            str(rate),
            "--seconds",
            str(seconds),
            "--port",
            str(port),
            "--rays",
            str(rays),
        ]
        if binary:
            command.append("--binary")
        if role == "imu":
            command += ["--batch", str(imu_batch)]
        clients.append(
            subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        )
    return clients


def _idle_percent(pid: int) -> float:
    """[% of one core] the process uses over IDLE_S with nothing to do."""
    before, wall = _Cpu.read(pid), time.monotonic()
    time.sleep(IDLE_S)
    return _Cpu.read(pid).percent_since(before, time.monotonic() - wall)


def _stop_all(
    daemon: subprocess.Popen[str],
    clients: list[subprocess.Popen[str]],
    viewer: subprocess.Popen[str] | None,
    program: subprocess.Popen[bytes] | None,
) -> None:
    if program is not None:
        program.terminate()
        program.wait(10)
    if viewer is not None and viewer.poll() is None:
        viewer.kill()
    for client in clients:
        if client.stdin is not None:
            client.stdin.close()  # done: a client that has sent all ends with its input
    for client in clients:
        try:
            client.wait(5)
        except subprocess.TimeoutExpired:  # still streaming: the run was cut short
            client.terminate()
            client.wait(5)
    daemon.terminate()
    daemon.wait(10)


def _percent_since(
    process: subprocess.Popen[bytes] | None, before: _Cpu | None, wall_s: float
) -> float | None:
    """[% of one core] a process used since ``before`` (None without the process)."""
    if process is None or before is None:
        return None
    return _Cpu.read(process.pid).percent_since(before, wall_s)


def _say(clients: list[subprocess.Popen[str]], line: str) -> None:
    for client in clients:
        assert client.stdin is not None
        client.stdin.write(line + "\n")
        client.stdin.flush()


def _ready(client: subprocess.Popen[str]) -> dict[str, Any]:
    """The next line a client process says (when it is connected, or has its terminal, or
    has sent all)."""
    assert client.stdout is not None
    said: dict[str, Any] = json.loads(client.stdout.readline())
    return said


def _start_lidar_program(port: int, tty: str) -> subprocess.Popen[bytes]:
    """``navd sensor ld06`` on the emulated lidar's terminal, once navd lists it."""
    navd = f"127.0.0.1:{port}"
    program = subprocess.Popen(
        [*SENSOR_PROGRAM, "--port", tty, "--navd", navd, "--device-id", "lidar0"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 15.0
    while not any(d.device_id == "lidar0" for d in _status(port).devices):
        if time.monotonic() > deadline or program.poll() is not None:
            raise RuntimeError("navd sensor ld06 did not connect to navd")
        time.sleep(0.2)
    return program


def _start_viewer(port: int) -> subprocess.Popen[str]:
    """A viewer subscribed to every channel of the live view on ``port``, once connected."""
    viewer = subprocess.Popen(
        [sys.executable, "-m", "navd.bench.viewer_client", "--port", str(port)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert viewer.stdout is not None
    json.loads(viewer.stdout.readline())  # connected
    return viewer


def _stop_viewer(viewer: subprocess.Popen[str]) -> dict[str, int]:
    """How many messages of each topic the viewer received."""
    assert viewer.stdin is not None and viewer.stdout is not None
    viewer.stdin.close()
    received: dict[str, int] = json.loads(viewer.stdout.readline())["received"]
    viewer.wait(10)
    return received


def _wait_settled(pid: int, limit_s: float = 30.0) -> None:
    """Wait until the process uses under SETTLED_PERCENT of a core over half a second."""
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        before, wall = _Cpu.read(pid), time.monotonic()
        time.sleep(0.5)
        if _Cpu.read(pid).percent_since(before, time.monotonic() - wall) < SETTLED_PERCENT:
            return
    raise RuntimeError(f"navd still busy {limit_s} s after start-up")


def _wait_listening(port: int, daemon: subprocess.Popen[str]) -> None:
    deadline = time.monotonic() + 15.0
    while time.monotonic() < deadline:
        if daemon.poll() is not None:
            raise RuntimeError(
                f"navd exited during start-up: {daemon.stderr.read() if daemon.stderr else ''}"
            )
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.2):
                return
        except OSError:
            time.sleep(0.05)
    raise RuntimeError("navd did not start listening within 15 s")
