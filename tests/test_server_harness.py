"""Helpers for the server tests (no tests here): the real app under uvicorn in a background thread, on a free
port, with a temporary SQLite file; httpx for REST and the ``websockets`` sync client for websockets."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import httpx
import uvicorn

from controllers.registry import ControllerSpec
from server.app import create_app
from server.settings import Settings

STARTUP_TIMEOUT_S = 90.0  # the planner worker's first start imports and warms numba kernels


def server_settings(db_path: Path, **overrides: Any) -> Settings:
    """Settings for a test server: the given SQLite file, no 3D view, fast races unless overridden."""
    values: dict[str, Any] = {
        "database_url": f"sqlite:///{db_path}",
        "viewer_enabled": False,
        "speedup": 10.0,
        "keep_finished_s": 30.0,
    }
    values.update(overrides)
    return Settings(**values)


class LiveServer:
    """``create_app(settings)`` served by uvicorn in a thread (a context manager)."""

    def __init__(self, settings: Settings, controllers: Mapping[str, ControllerSpec] | None = None) -> None:
        self.settings = settings
        self.controllers = controllers
        self._server: uvicorn.Server | None = None
        self._thread: threading.Thread | None = None
        self.port = 0

    @property
    def url(self) -> str:
        """``http://127.0.0.1:PORT``."""
        return f"http://127.0.0.1:{self.port}"

    @property
    def ws_url(self) -> str:
        """``ws://127.0.0.1:PORT``."""
        return f"ws://127.0.0.1:{self.port}"

    def __enter__(self) -> LiveServer:
        app = create_app(self.settings, controllers=self.controllers)
        config = uvicorn.Config(
            app,
            loop="server.loop:new_precise_loop",
            ws_per_message_deflate=False,
            log_level="warning",
            lifespan="on",
        )
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(("127.0.0.1", 0))
        self.port = sock.getsockname()[1]
        self._server = server = uvicorn.Server(config)
        self._thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
        self._thread.start()
        give_up = time.monotonic() + STARTUP_TIMEOUT_S
        while not server.started:
            if not self._thread.is_alive() or time.monotonic() > give_up:
                raise RuntimeError("the test server did not start")
            time.sleep(0.05)
        return self

    def __exit__(self, *exc: object) -> None:
        assert self._server is not None and self._thread is not None
        self._server.should_exit = True
        self._thread.join(60)

    def client(self) -> httpx.Client:
        """An httpx client for this server."""
        return httpx.Client(base_url=self.url, timeout=30.0)


def wait_for(condition: Callable[[], Any], timeout: float, interval: float = 0.05) -> Any:
    """Poll ``condition`` until it returns something truthy (returned) or ``timeout`` [s] passes."""
    give_up = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > give_up:
            raise AssertionError(f"condition not met within {timeout} s")
        time.sleep(interval)


def start_race(client: httpx.Client, **body: Any) -> dict[str, Any]:
    """POST /api/races; returns the created race."""
    response = client.post("/api/races", json=body)
    assert response.status_code == 201, response.text
    race: dict[str, Any] = response.json()
    return race


def wait_status(client: httpx.Client, race_id: str, statuses: tuple[str, ...], timeout: float) -> dict[str, Any]:
    """Poll GET /api/races/{id} until its status is one of ``statuses``; returns the race."""

    def reached() -> dict[str, Any] | None:
        race: dict[str, Any] = client.get(f"/api/races/{race_id}").json()
        return race if race["status"] in statuses else None

    result: dict[str, Any] = wait_for(reached, timeout, 0.1)
    return result
