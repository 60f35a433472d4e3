"""A real server for tests: an ASGI app under uvicorn in a background thread, on a free local port, with the
server's own event loop (:func:`server.loop.new_precise_loop`); for the race server, a temporary SQLite file.
httpx for REST and the ``websockets`` clients for websockets."""

from __future__ import annotations

import asyncio
import socket
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Self

import httpx
import uvicorn
from fastapi import FastAPI

from server.loop import new_precise_loop
from server.settings import Settings

if TYPE_CHECKING:
    from controllers.registry import ControllerSpec

STARTUP_TIMEOUT_S = 90.0  # the planner worker's first start imports and warms numba kernels


class ServerThread:
    """``app`` served by uvicorn in a daemon thread (a context manager). ``lifespan="off"`` for bare routers;
    ``options`` go to ``uvicorn.Config``."""

    def __init__(self, app: FastAPI, *, lifespan: Literal["on", "off"] = "on", **options: Any) -> None:
        self.app = app
        config = uvicorn.Config(app, ws_per_message_deflate=False, log_level="warning", lifespan=lifespan, **options)
        self.server = uvicorn.Server(config)
        self.loop: asyncio.AbstractEventLoop | None = None
        self.port = 0
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        """``http://127.0.0.1:PORT``."""
        return f"http://127.0.0.1:{self.port}"

    @property
    def ws_url(self) -> str:
        """``ws://127.0.0.1:PORT``."""
        return f"ws://127.0.0.1:{self.port}"

    def _run(self, sock: socket.socket) -> None:
        self.loop = loop = new_precise_loop()
        try:
            loop.run_until_complete(self.server.serve(sockets=[sock]))
        finally:
            loop.close()

    def __enter__(self) -> Self:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(("127.0.0.1", 0))
        self.port = sock.getsockname()[1]
        self._thread = threading.Thread(target=self._run, args=(sock,), daemon=True)
        self._thread.start()
        give_up = time.monotonic() + STARTUP_TIMEOUT_S
        while not self.server.started:
            if not self._thread.is_alive() or time.monotonic() > give_up:
                raise RuntimeError("the test server did not start")
            time.sleep(0.02)
        return self

    def __exit__(self, *exc: object) -> None:
        assert self._thread is not None
        self.server.should_exit = True
        self._thread.join(60)

    def client(self) -> httpx.Client:
        """An httpx client for this server."""
        return httpx.Client(base_url=self.url, timeout=30.0)

    def task_names(self) -> set[str]:
        """Names of the tasks now alive on the server's loop."""
        assert self.loop is not None

        async def names() -> set[str]:
            return {t.get_name() for t in asyncio.all_tasks() if t is not asyncio.current_task()}

        return asyncio.run_coroutine_threadsafe(names(), self.loop).result(5)


class LiveServer(ServerThread):
    """The race server, ``create_app(settings, controllers=controllers)``, with its lifespan and the connection
    limits ``karting serve`` uses (:func:`server.app.connection_options`)."""

    def __init__(self, settings: Settings, controllers: Mapping[str, ControllerSpec] | None = None) -> None:
        from server.app import connection_options, create_app

        self.settings = settings
        super().__init__(create_app(settings, controllers=controllers), **connection_options(settings))


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
