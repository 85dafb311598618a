"""The operator page's HTTP server: the package's page files and config.json, nothing else."""

from __future__ import annotations

import json
import socket
import time
import urllib.error
import urllib.request
from collections.abc import Iterator

import pytest

from navd.viz.page_server import HEADER_DEADLINE_S, MAX_CONNECTIONS, PAGE_FILES, PageServer


@pytest.fixture
def page() -> Iterator[PageServer]:
    server = PageServer("127.0.0.1", 0, ws_port=9999, robot="rover", command_token="t0k")
    try:
        yield server
    finally:
        server.stop()


def _get(server: PageServer, path: str, method: str = "GET") -> tuple[int, str, bytes]:
    request = urllib.request.Request(f"http://127.0.0.1:{server.port}{path}", method=method)
    try:
        with urllib.request.urlopen(request, timeout=5) as answer:
            return answer.status, answer.headers["Content-Type"], answer.read()
    except urllib.error.HTTPError as err:
        return err.code, err.headers["Content-Type"], b""


def test_the_page_and_its_files_are_served_with_their_types(page: PageServer) -> None:
    status, kind, body = _get(page, "/")
    assert status == 200 and kind.startswith("text/html")
    assert b'<canvas id="map"' in body and b'type="module" src="page.js"' in body
    for path, wanted in (("/page.js", "text/javascript"), ("/page.css", "text/css")):
        status, kind, body = _get(page, path)
        assert status == 200 and kind.startswith(wanted) and body == PAGE_FILES[path]
    status, kind, body = _get(page, "/page.js", method="HEAD")
    assert status == 200 and body == b""


def test_config_json_says_where_the_stream_is(page: PageServer) -> None:
    status, kind, body = _get(page, "/config.json?nocache=1")
    assert status == 200 and kind == "application/json"
    assert json.loads(body) == {"ws_port": 9999, "robot": "rover", "command_token": "t0k"}


@pytest.mark.parametrize("path", ["/../pyproject.toml", "/%2e%2e/navd/app.py", "/nothing.js"])
def test_nothing_outside_the_page_is_served(page: PageServer, path: str) -> None:
    status, _, body = _get(page, path)
    assert status == 404 and body == b""


def test_a_busy_port_is_an_error_naming_the_address() -> None:
    first = PageServer("127.0.0.1", 0, ws_port=1, robot="a", command_token="a")
    try:
        with pytest.raises(OSError, match="in use"):
            PageServer("127.0.0.1", first.port, ws_port=1, robot="b", command_token="b")
    finally:
        first.stop()


def test_connections_holding_every_slot_never_keep_the_page_away(page: PageServer) -> None:
    held = []
    try:
        for _ in range(MAX_CONNECTIONS + 8):  # slowloris: a request begun, never finished
            conn = socket.create_connection(("127.0.0.1", page.port), timeout=5)
            conn.sendall(b"GET / HTTP/1.1\r\nHost: robot\r\n")
            held.append(conn)
        status, _, content = _get(page, "/")  # the oldest unfinished request made room
        assert status == 200 and content == PAGE_FILES["/"]
        assert held[0].recv(1) == b""  # closed for it
    finally:
        for conn in held:
            conn.close()


def test_a_request_dribbled_slower_than_its_deadline_is_cut_off(page: PageServer) -> None:
    conn = socket.create_connection(("127.0.0.1", page.port), timeout=5)
    began = time.monotonic()
    conn.sendall(b"GET / HTTP/1.1\r\n")
    try:
        for _ in range(60):  # a header line a second: never idle, never done
            time.sleep(1.0)
            conn.sendall(b"X-Slow: 1\r\n")
        raise AssertionError("a request dribbled for 60 s was still being read")
    except OSError:
        pass  # cut off (a send to a closed connection fails)
    finally:
        conn.close()
    assert time.monotonic() - began >= HEADER_DEADLINE_S
