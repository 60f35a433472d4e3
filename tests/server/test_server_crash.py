"""A server killed with SIGKILL leaves nothing behind: the real server (``karting serve`` in a subprocess) races,
runs a tournament and is killed; within 5 s none of its processes (planner worker, controller host, resource
tracker, fork server, tournament workers) is alive, and a server restarted on the same database shows the
finished race exactly as before, the race it was running as aborted and the tournament as stopped."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from support.live_server import STARTUP_TIMEOUT_S, wait_for, wait_status
from support.processes import descendants, describe, survivors_after

ROOT = Path(__file__).resolve().parents[2]
RACE = {"track": "oval", "laps": 1, "karts": [{"controller": "fixed-lqng"}, {"controller": "lane-follower"}]}
LONG_RACE = {**RACE, "laps": 20}
TOURNAMENT = {"agents": ["fixed-lqng", "lane-follower"], "tracks": ["oval"], "races_per_pair": 50, "laps": 1}


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


class ServerProcess:
    """``karting serve`` on a free loopback port and the given database, in its own process."""

    def __init__(self, db: Path) -> None:
        self.port = free_port()
        env = {
            **os.environ,
            "PYTHONPATH": str(ROOT),
            "KARTING_SPEEDUP": "10",
            "KARTING_CONTROLLER_HOSTS": "1",
            "KARTING_TOURNAMENT_WORKERS": "2",
        }
        args = [sys.executable, "-m", "karting", "serve", "--port", str(self.port), "--db", str(db), "--no-viewer"]
        self.process = subprocess.Popen(args, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.client = httpx.Client(base_url=f"http://127.0.0.1:{self.port}", timeout=30.0)
        wait_for(self._up, STARTUP_TIMEOUT_S, 0.2)

    def _up(self) -> bool:
        assert self.process.poll() is None, "the server exited"
        try:
            return self.client.get("/api/tracks").status_code == 200
        except httpx.TransportError:
            return False

    def stop(self) -> None:
        self.client.close()
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(30)
            except subprocess.TimeoutExpired:
                self.process.kill()


@pytest.fixture
def db(tmp_path: Path) -> Iterator[Path]:
    yield tmp_path / "karting.db"


def test_a_killed_server_leaves_no_process_and_its_results_intact(db: Path) -> None:
    server = ServerProcess(db)
    try:
        client = server.client
        finished = client.post("/api/races", json=RACE).json()
        wait_status(client, finished["id"], ("finished",), 120)
        result: dict[str, Any] = client.get(f"/api/races/{finished['id']}/result").json()
        replay = client.get(f"/api/races/{finished['id']}/replay").json()
        running = client.post("/api/races", json=LONG_RACE).json()
        wait_status(client, running["id"], ("running",), 60)
        tournament = client.post("/api/tournaments", json=TOURNAMENT).json()

        def workers_up() -> list[Any]:
            tree = descendants(server.process.pid)
            return tree if len(tree) >= 5 else []  # planner, host, tracker, fork server, a tournament worker

        tree = wait_for(workers_up, 120, 0.2)
        server.process.send_signal(signal.SIGKILL)
        server.process.wait(10)
        left = survivors_after(tree, 5.0)
        assert not left, describe(left)
    finally:
        server.stop()

    again = ServerProcess(db)
    try:
        client = again.client
        assert client.get(f"/api/races/{finished['id']}/result").json() == result
        assert client.get(f"/api/races/{finished['id']}/replay").json() == replay
        assert client.get(f"/api/races/{running['id']}").json()["status"] == "aborted"
        assert client.get(f"/api/tournaments/{tournament['id']}").json()["status"] == "stopped"
    finally:
        again.stop()
