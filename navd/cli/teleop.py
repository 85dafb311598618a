"""``navd teleop``: drive the robot by hand with the arrow keys.

Up and down drive forward and back, left and right turn on the spot; a key's motion lasts
while the key is held (the terminal repeats it) and ``HOLD_S`` past the last repeat, then
the program stops sending and the robot stops (the daemon's deadman: no command for
``safety.reaction_timeout_s``). Space stops at once; ``e`` engages the emergency stop (the
robot stays still, whoever drives, until ``r`` or another client releases it); ``+`` and
``-`` change the speed; ``q`` or Ctrl-C quits. Every command passes the daemon's safety
gate, so a wall still stops the robot. The status line shows who drives and why the robot
is held, if it is.

Keys also come from a pipe (``printf '\\033[A' | navd teleop``), for scripts and tests.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import select
import sys
import termios
import threading
import time
import tty
from collections.abc import Iterator
from dataclasses import dataclass

from navd.cli.common import EXIT_FAILED, EXIT_OK, Commands, connect, connection_options
from navd.config import ConfigError
from navd.wire import (
    Client,
    ClientError,
    EmergencyStopFrame,
    ErrorFrame,
    StatusFrame,
    SubscribeFrame,
    TeleopFrame,
)

__all__ = ["KeyDriver", "add_commands"]

SEND_PERIOD_S = 0.1  # [s] commands go out at 10 Hz while a key is held
# [s] a key's motion lasts this long past its last repeat: longer than a terminal's delay
# before it starts repeating a held key (typically 0.25-0.6 s), so holding a key is smooth.
HOLD_S = 0.7
SPEED_STEP = 1.25  # each + or - multiplies or divides the speeds by this
STATUS_RATE_HZ = 2.0

UP, DOWN, RIGHT, LEFT = b"\x1b[A", b"\x1b[B", b"\x1b[C", b"\x1b[D"
QUIT = (b"q", b"Q", b"\x03")
ESTOP, RELEASE = (b"e", b"E"), (b"r", b"R")  # the emergency stop, and its release


@dataclass
class KeyDriver:
    """What the keys ask for, given when they came (no terminal, no socket: testable).

    Attributes:
        linear_mps: [m/s] speed of the up and down keys.
        angular_radps: [rad/s] yaw rate of the left and right keys.
    """

    linear_mps: float
    angular_radps: float
    _command: tuple[float, float] = (0.0, 0.0)
    _held_until: float = -1.0
    quit: bool = False
    stop_request: bool | None = None  # an emergency stop (True) or release (False) to send

    def key(self, key: bytes, now: float) -> None:
        """Take one key (an arrow's escape sequence or a character) at ``now`` [s]."""
        motion = {
            UP: (self.linear_mps, 0.0),
            DOWN: (-self.linear_mps, 0.0),
            LEFT: (0.0, self.angular_radps),
            RIGHT: (0.0, -self.angular_radps),
        }.get(key)
        if motion is not None:
            self._command = motion
            self._held_until = now + HOLD_S
        elif key == b" ":
            self._command = (0.0, 0.0)
            self._held_until = now  # one zero goes out, then nothing
        elif key in (b"+", b"="):
            self._scale(SPEED_STEP)
        elif key in (b"-", b"_"):
            self._scale(1.0 / SPEED_STEP)
        elif key in ESTOP:
            self.stop_request = True
            self._command, self._held_until = (0.0, 0.0), now
        elif key in RELEASE:
            self.stop_request = False
        elif key in QUIT:
            self.quit = True

    def _scale(self, factor: float) -> None:
        self.linear_mps *= factor
        self.angular_radps *= factor
        linear, angular = self._command
        self._command = (linear * factor, angular * factor)

    def command(self, now: float) -> tuple[float, float] | None:
        """The command to send at ``now`` [s]: the held key's motion, one zero just after
        it ends (so the robot stops at once, not at the deadman), then None (send nothing)."""
        if now <= self._held_until:
            return self._command
        if self._command != (0.0, 0.0) or self._held_until >= 0.0:
            self._command = (0.0, 0.0)
            self._held_until = -1.0
            return (0.0, 0.0)
        return None


def split_keys(data: bytes) -> tuple[list[bytes], bytes]:
    """Bytes read from a terminal as keys: arrow escape sequences whole, others one by one;
    and the start of a sequence cut off at the end of ``data`` (to go before the next read)."""
    keys: list[bytes] = []
    i = 0
    while i < len(data):
        rest = data[i:]
        if rest in (b"\x1b", b"\x1b["):
            return keys, rest  # the rest of the sequence comes with the next read
        if rest.startswith(b"\x1b["):
            keys.append(data[i : i + 3])
            i += 3
        else:
            keys.append(data[i : i + 1])
            i += 1
    return keys, b""


def add_commands(commands: Commands) -> None:
    """Add ``teleop``."""
    teleop = commands.add_parser(
        "teleop", help="drive the robot by hand with the arrow keys (q quits)"
    )
    teleop.add_argument(
        "--speed", type=float, default=0.3, help="[m/s] forward speed of the up key (0.3)"
    )
    teleop.add_argument(
        "--turn", type=float, default=0.8, help="[rad/s] yaw rate of the left and right keys (0.8)"
    )
    connection_options(teleop)
    teleop.set_defaults(handler=_teleop)


@contextlib.contextmanager
def _raw_terminal(fd: int) -> Iterator[None]:
    """Keys one at a time, unechoed, while inside; the terminal as it was afterwards."""
    if not os.isatty(fd):
        yield
        return
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


class _Replies:
    """Reads everything navd sends on the connection, in a thread (so nothing piles up
    unread): the latest status is shown, and errors too."""

    def __init__(self, client: Client, interactive: bool) -> None:
        self.line = "waiting for status"
        self._client = client
        self._interactive = interactive
        threading.Thread(target=self._run, name="teleop-replies", daemon=True).start()

    def _run(self) -> None:
        with contextlib.suppress(ClientError, OSError, ValueError):
            while True:
                reply = self._client.receive()
                if isinstance(reply, StatusFrame):
                    held = "; ".join(reply.diagnostics.safety)
                    who = f" by {reply.operator}" if reply.operator else ""
                    self.line = f"[{reply.mode}{who}]" + (f" held: {held}" if held else "")
                elif isinstance(reply, ErrorFrame):
                    self.line = f"refused: {reply.describe()}"
                    if not self._interactive:
                        print(f"navd teleop: {reply.describe()}", file=sys.stderr, flush=True)


def _teleop(args: argparse.Namespace) -> int:
    keys = KeyDriver(args.speed, args.turn)
    fd = sys.stdin.fileno()
    interactive = os.isatty(fd)
    try:
        with connect(args) as client, _raw_terminal(fd):
            client.request(SubscribeFrame(rate_hz=STATUS_RATE_HZ))
            client.timeout_s = None  # the reader waits for as long as the session lasts
            client.sock.settimeout(None)
            replies = _Replies(client, interactive)
            if interactive:
                print(
                    "arrows drive, space stops, e: emergency stop, r: release it, "
                    "+ and - change speed, q quits",
                    flush=True,
                )
            _drive(client, keys, fd, replies if interactive else None)
    except (ClientError, ConfigError, OSError) as err:
        print(f"\nnavd teleop: {err}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        pass
    return EXIT_OK


def _drive(client: Client, keys: KeyDriver, fd: int, watch: _Replies | None) -> None:
    """Read keys and send commands until quit (or the end of piped input, once the last
    key's motion is over)."""
    send = client.send
    next_send = time.monotonic()
    ended = False
    pending = b""
    try:
        while not keys.quit:
            now = time.monotonic()
            ready, _, _ = select.select([] if ended else [fd], [], [], max(0.0, next_send - now))
            if ready:
                data = os.read(fd, 64)
                if not data:
                    ended = True  # piped input is over: finish the motion it asked for
                split, pending = split_keys(pending + data)
                for key in split:
                    keys.key(key, time.monotonic())
                if keys.stop_request is not None:  # at once, not at the next period
                    send(EmergencyStopFrame(engaged=keys.stop_request))
                    keys.stop_request = None
            now = time.monotonic()
            if now < next_send:
                continue
            next_send = now + SEND_PERIOD_S
            command = keys.command(now)
            if command is not None:
                send(TeleopFrame(linear_x=command[0], angular_z=command[1]))
            elif ended:
                return
            if watch is not None:
                shown = "stopped" if command is None else f"v {command[0]:+.2f} w {command[1]:+.2f}"
                sys.stdout.write(f"\r{shown:<20} {watch.line:<70}")
                sys.stdout.flush()
    finally:  # q, Ctrl-C or the end: the robot stops now, not at the deadman
        with contextlib.suppress(OSError):
            send(TeleopFrame(linear_x=0.0, angular_z=0.0))
