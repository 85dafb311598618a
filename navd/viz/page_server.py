"""The operator page's HTTP server: the page's files from the package, and where its
WebSocket stream is.

The standard library's threading HTTP server, in a thread of its own (never the event
loop's). It answers GET and HEAD for the files in ``navd/viz/page`` only (no listing, no
path outside them) and ``/config.json`` ({"ws_port", "robot"}), so the page, loaded from
``http://ROBOT:PAGE_PORT/``, connects to ``ws://ROBOT:WS_PORT``. No build step, nothing
fetched from elsewhere: it works offline and on a phone.

``/config.json`` also carries the run's command token to a browser on this machine (the
peer is loopback and the page was asked for by a loopback name, so a site whose name
resolves to 127.0.0.1 does not get it): the page on the robot, or through an SSH tunnel,
steers without typing a secret, while other web pages, which cannot read another origin's
answers, cannot. Each connection is served by a thread of its own, at most
``MAX_CONNECTIONS`` at once, and dropped after ``IDLE_TIMEOUT_S`` of silence. A request must
be whole within ``HEADER_DEADLINE_S`` of connecting, however slowly its bytes trickle in, and
a new connection finding every slot taken closes the oldest one still sending its request:
clients that open connections and dribble headers (slowloris) never keep the page from the
operator.
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import socket
import sys
import threading
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any

__all__ = ["HEADER_DEADLINE_S", "IDLE_TIMEOUT_S", "MAX_CONNECTIONS", "PAGE_FILES", "PageServer"]

MAX_CONNECTIONS = 32
IDLE_TIMEOUT_S = 10.0  # [s] a connection that sends nothing this long is closed
HEADER_DEADLINE_S = 5.0  # [s] from connecting to the end of the request's headers
EVICTED_WAIT_S = 1.0  # [s] the most a new connection waits for an evicted one's slot

_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".svg": "image/svg+xml",
}


def _page_files() -> dict[str, bytes]:
    """The page's files by URL path, read once from the package."""
    folder = resources.files("navd.viz") / "page"
    files = {
        f"/{item.name}": item.read_bytes()
        for item in folder.iterdir()
        if item.is_file() and any(item.name.endswith(ext) for ext in _TYPES)
    }
    files["/"] = files["/index.html"]
    return files


PAGE_FILES = _page_files()


def _loopback_address(address: str) -> bool:
    try:
        return ipaddress.ip_address(address.split("%", 1)[0]).is_loopback
    except ValueError:
        return False


def _loopback_name(host_header: str | None) -> bool:
    """True if a Host header names this machine by loopback (``localhost``, 127.x, [::1])."""
    if not host_header:
        return False
    host = host_header.rsplit(":", 1)[0] if not host_header.startswith("[") else host_header
    host = host.split("]", 1)[0].lstrip("[")
    return host == "localhost" or _loopback_address(host)


class _Handler(BaseHTTPRequestHandler):
    server: _Server
    timeout = IDLE_TIMEOUT_S

    def do_GET(self) -> None:
        self._answer(body=True)

    def do_HEAD(self) -> None:
        self._answer(body=False)

    def _answer(self, *, body: bool) -> None:
        self.server.requested(self.request)
        path = self.path.split("?", 1)[0]
        if path == "/config.json":
            config = dict(self.server.config)
            if _loopback_address(self.client_address[0]) and _loopback_name(
                self.headers.get("Host")
            ):
                config["command_token"] = self.server.command_token
            content, kind = json.dumps(config).encode(), "application/json"
        elif path in PAGE_FILES:
            content = PAGE_FILES[path]
            name = "/index.html" if path == "/" else path
            kind = _TYPES[name[name.rindex(".") :]]
        else:
            self.send_error(HTTPStatus.NOT_FOUND, "no such page file")
            return
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(content)))
        self.send_header("Cache-Control", "no-store")  # an upgraded navd serves its new page
        self.end_headers()
        if body:
            self.wfile.write(content)

    def log_message(self, format: str, *args: Any) -> None:
        """Requests are not logged (a phone polling the page would fill the journal)."""


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    config: dict[str, object]
    command_token: str
    slots = threading.BoundedSemaphore(MAX_CONNECTIONS)
    # connections still sending their request -> [s, monotonic] when each was accepted
    waiting: dict[socket.socket, float]
    lock = threading.Lock()

    def process_request(self, request: Any, client_address: Any) -> None:
        """A thread per connection while fewer than MAX_CONNECTIONS are served; beyond,
        the oldest connection still sending its request is closed for it (or, if every one
        is being answered, the new one is)."""
        if not self.slots.acquire(blocking=False) and (
            not self._evict_oldest() or not self.slots.acquire(timeout=EVICTED_WAIT_S)
        ):
            self.shutdown_request(request)
            return
        with self.lock:
            self.waiting[request] = time.monotonic()
        try:
            super().process_request(request, client_address)
        except BaseException:
            self.requested(request)
            self.slots.release()
            raise

    def process_request_thread(self, request: Any, client_address: Any) -> None:
        try:
            super().process_request_thread(request, client_address)
        finally:
            self.requested(request)
            self.slots.release()

    def handle_error(self, request: Any, client_address: Any) -> None:
        """A browser that went away mid-answer (or a connection cut at its deadline) is not
        an error; anything else is printed as the standard library does."""
        if isinstance(sys.exception(), ConnectionError):
            return
        super().handle_error(request, client_address)

    def requested(self, request: Any) -> None:
        """``request``'s connection has sent its request (or is gone)."""
        with self.lock:
            self.waiting.pop(request, None)

    def service_actions(self) -> None:
        """Each poll of the server's thread: close the connections whose request is not
        whole within HEADER_DEADLINE_S (their threads end on the closed socket)."""
        late = time.monotonic() - HEADER_DEADLINE_S
        with self.lock:
            overdue = [r for r, since in self.waiting.items() if since < late]
        for request in overdue:
            self._cut(request)

    def _evict_oldest(self) -> bool:
        with self.lock:
            oldest = min(self.waiting, key=self.waiting.__getitem__, default=None)
        if oldest is None:
            return False
        self._cut(oldest)
        return True

    def _cut(self, request: Any) -> None:
        self.requested(request)
        with contextlib.suppress(OSError):  # already closed by its thread
            request.shutdown(socket.SHUT_RDWR)


class _Server6(_Server):
    address_family = socket.AF_INET6


class PageServer:
    """Serves the page on ``host``:``port`` (0: a free port) for a stream on ``ws_port``,
    handing ``command_token`` to browsers on this machine (see the module docstring).

    Raises:
        OSError: the address cannot be bound (a busy port, an address not of this machine).
    """

    def __init__(self, host: str, port: int, ws_port: int, robot: str, command_token: str) -> None:
        server = _Server6 if ":" in host else _Server
        self._server = server((host, port), _Handler)
        self._server.slots = threading.BoundedSemaphore(MAX_CONNECTIONS)
        self._server.waiting = {}
        self._server.lock = threading.Lock()
        self._server.config = {"ws_port": ws_port, "robot": robot}
        self._server.command_token = command_token
        self._thread = threading.Thread(
            target=self._server.serve_forever, kwargs={"poll_interval": 0.2}, name="viz-page"
        )
        self._thread.daemon = True
        self._thread.start()

    @property
    def port(self) -> int:
        """The bound port."""
        return int(self._server.server_address[1])

    def stop(self) -> None:
        """Stop serving and close the socket (blocks up to a poll interval: not on the loop)."""
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(timeout=2.0)
