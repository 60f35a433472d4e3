"""A server killed with SIGKILL leaves nothing behind: the real server (``karting serve`` in a subprocess) races,
runs a tournament and is killed; within 5 s none of its processes (planner worker, controller host, resource
tracker, fork server, tournament workers) is alive, and a server restarted on the same database shows the
finished race exactly as before, the race it was running as aborted and the tournament as stopped."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from support.live_server import wait_for, wait_status
from support.processes import descendants, describe, survivors_after
from support.server_process import ServerProcess

pytestmark = pytest.mark.slow  # two real servers and their process trees

SETTINGS = {"speedup": "10", "controller_hosts": "1", "tournament_workers": "2"}
RACE = {"track": "oval", "laps": 1, "karts": [{"controller": "fixed-lqng"}, {"controller": "lane-follower"}]}
LONG_RACE = {**RACE, "laps": 20}
TOURNAMENT = {"agents": ["fixed-lqng", "lane-follower"], "tracks": ["oval"], "races_per_pair": 50, "laps": 1}


@pytest.fixture
def db(tmp_path: Path) -> Iterator[Path]:
    yield tmp_path / "karting.db"


def test_a_killed_server_leaves_no_process_and_its_results_intact(db: Path) -> None:
    server = ServerProcess(db, SETTINGS)
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

    again = ServerProcess(db, SETTINGS)
    try:
        client = again.client
        assert client.get(f"/api/races/{finished['id']}/result").json() == result
        assert client.get(f"/api/races/{finished['id']}/replay").json() == replay
        assert client.get(f"/api/races/{running['id']}").json()["status"] == "aborted"
        assert client.get(f"/api/tournaments/{tournament['id']}").json()["status"] == "stopped"
    finally:
        again.stop()
