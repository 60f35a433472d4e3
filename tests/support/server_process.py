"""The race server as ``karting serve`` in a process of its own (for crash and memory tests: its process tree
and memory are its own), on a free loopback port."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

import httpx

from support.live_server import STARTUP_TIMEOUT_S, wait_for

ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


class ServerProcess:
    """``karting serve --no-viewer`` on the SQLite file ``db``; ``settings`` as ``KARTING_*`` variables."""

    def __init__(self, db: Path, settings: Mapping[str, str] | None = None) -> None:
        self.port = free_port()
        env = {
            **os.environ,
            "PYTHONPATH": str(ROOT),
            **{f"KARTING_{k.upper()}": v for k, v in (settings or {}).items()},
        }
        args = [sys.executable, "-m", "karting", "serve", "--port", str(self.port), "--db", str(db), "--no-viewer"]
        self.process = subprocess.Popen(args, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.client = httpx.Client(base_url=self.url, timeout=30.0)
        try:
            wait_for(self._up, STARTUP_TIMEOUT_S, 0.2)
        except BaseException:
            self.stop()
            raise

    @property
    def url(self) -> str:
        """``http://127.0.0.1:PORT``."""
        return f"http://127.0.0.1:{self.port}"

    @property
    def ws_url(self) -> str:
        """``ws://127.0.0.1:PORT``."""
        return f"ws://127.0.0.1:{self.port}"

    def _up(self) -> bool:
        assert self.process.poll() is None, "the server exited"
        try:
            return self.client.get("/api/tracks").status_code == 200
        except httpx.TransportError:
            return False

    def stop(self) -> None:
        """Stop the server (SIGTERM, then SIGKILL after 30 s)."""
        self.client.close()
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(10)
