"""Connections that do nothing do not stay: an idle HTTP keep-alive connection and a websocket whose client never
answers the server's pings (half-open) are closed after the settings' timeouts; and each race's 3D view
server listens on loopback only."""

from __future__ import annotations

import base64
import os
import socket
import time
from collections.abc import Iterator
from typing import Any

import httpx
import psutil
import pytest
from support.live_server import LiveServer, server_settings, start_race, wait_for, wait_status

KEEP_ALIVE_S = 0.5
PING_S = 0.5


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("connections") / "karting.db"
    settings = server_settings(
        db,
        viewer_enabled=True,
        human_wait_s=600.0,
        keep_alive_timeout_s=KEEP_ALIVE_S,
        ws_ping_interval_s=PING_S,
        ws_ping_timeout_s=PING_S,
    )
    with LiveServer(settings) as server:
        yield server


@pytest.fixture(scope="module")
def race(live: LiveServer) -> Iterator[dict[str, Any]]:
    with live.client() as client:
        created = start_race(client, track="oval", laps=1, karts=[{"controller": "human"}])
        wait_status(client, created["id"], ("waiting",), 60)
        yield created
        client.post(f"/api/races/{created['id']}/stop")


def seconds_until_closed(sock: socket.socket, limit: float) -> float:
    """Read (and drop) what the server sends until it closes the connection; the seconds that took."""
    start = time.monotonic()
    sock.settimeout(limit)
    while sock.recv(65536):
        assert time.monotonic() - start < limit, "the server kept the connection open"
    return time.monotonic() - start


def test_an_idle_keep_alive_connection_is_closed(live: LiveServer) -> None:
    with socket.create_connection(("127.0.0.1", live.port), timeout=10) as sock:
        sock.sendall(b"GET /api/tracks HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: keep-alive\r\n\r\n")
        assert sock.recv(65536).startswith(b"HTTP/1.1 200")
        assert seconds_until_closed(sock, 30 * KEEP_ALIVE_S) >= KEEP_ALIVE_S * 0.5


def test_a_websocket_that_never_answers_pings_is_closed(live: LiveServer, race: dict[str, Any]) -> None:
    key = base64.b64encode(os.urandom(16)).decode()
    request = (
        f"GET /api/races/{race['id']}/telemetry HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
        f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
    )
    with socket.create_connection(("127.0.0.1", live.port), timeout=10) as sock:
        sock.sendall(request.encode())
        assert sock.recv(65536).startswith(b"HTTP/1.1 101")
        # a client that reads but never answers a ping: the server gives up after the interval and the timeout
        assert seconds_until_closed(sock, 30 * PING_S) >= PING_S


def test_the_3d_view_listens_on_loopback_only(live: LiveServer, race: dict[str, Any]) -> None:
    port = wait_for(lambda: live.app.state.races.scene_port(race["id"]), 30)
    listening = [c for c in psutil.Process().net_connections(kind="inet") if c.status == psutil.CONN_LISTEN and c.laddr]
    addresses = {c.laddr.ip for c in listening if c.laddr.port == port}
    assert addresses == {"127.0.0.1"}
    with httpx.Client() as client:  # and it answers there
        assert client.get(f"http://127.0.0.1:{port}/").status_code < 500
