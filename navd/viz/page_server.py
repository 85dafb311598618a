"""The operator page's HTTP server: the page's files from the package, and where its
WebSocket stream is.

The standard library's threading HTTP server, in a thread of its own (never the event
loop's). It answers GET and HEAD for the files in ``navd/viz/page`` only (no listing, no
path outside them) and ``/config.json`` ({"ws_port", "robot"}), so the page, loaded from
``http://ROBOT:PAGE_PORT/``, connects to ``ws://ROBOT:WS_PORT``. No build step, nothing
fetched from elsewhere: it works offline and on a phone.
"""

from __future__ import annotations

import json
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any

__all__ = ["PAGE_FILES", "PageServer"]

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


class _Handler(BaseHTTPRequestHandler):
    server: _Server

    def do_GET(self) -> None:
        self._answer(body=True)

    def do_HEAD(self) -> None:
        self._answer(body=False)

    def _answer(self, *, body: bool) -> None:
        path = self.path.split("?", 1)[0]
        if path == "/config.json":
            content, kind = self.server.config_json, "application/json"
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
    config_json: bytes


class PageServer:
    """Serves the page on ``host``:``port`` (0: a free port) for a stream on ``ws_port``.

    Raises:
        OSError: the address cannot be bound (a busy port, an address not of this machine).
    """

    def __init__(self, host: str, port: int, ws_port: int, robot: str) -> None:
        self._server = _Server((host, port), _Handler)
        self._server.config_json = json.dumps({"ws_port": ws_port, "robot": robot}).encode()
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
