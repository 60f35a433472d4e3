"""No race waits forever: one whose human driver never comes is cancelled after the join timeout, one whose only
unfinished karts are absent or silent humans ends soon after, and the result says why (the humans did not
finish)."""

from __future__ import annotations

import json
from collections.abc import Iterator

import httpx
import pytest
from support.live_server import LiveServer, server_settings, start_race, wait_status
from websockets.sync.client import connect

JOIN_S = 1.0  # [s] human_wait_s of this server
STUCK_S = 1.0  # [s] abandoned_race_s of this server
HUMAN = {"controller": "human", "name": "Ada"}


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("ends") / "karting.db"
    settings = server_settings(db, speedup=30.0, human_wait_s=JOIN_S, abandoned_race_s=STUCK_S, countdown_s=0.0)
    with LiveServer(settings) as server:
        yield server


@pytest.fixture(scope="module")
def client(live: LiveServer) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


def test_a_race_whose_driver_never_comes_is_cancelled(client: httpx.Client) -> None:
    race = start_race(client, track="oval", laps=1, karts=[HUMAN, {"controller": "lane-follower"}])
    ended = wait_status(client, race["id"], ("cancelled", "running", "finished"), 60)
    assert ended["status"] == "cancelled" and ended["step"] == 0  # it never ran
    result = client.get(f"/api/races/{race['id']}/result").json()
    assert result["status"] == "cancelled"
    assert result["end_reason"] == f"no driver joined kart(s) 0 within {JOIN_S:g} s (KARTING_HUMAN_WAIT_S)"
    assert not any(k["finished"] for k in result["karts"])
    live = [r for r in client.get("/api/races").json() if r["id"] == race["id"]]
    assert live and live[0]["status"] == "cancelled"  # its live slot is free


@pytest.mark.parametrize("driver", ["silent", "gone"])
def test_a_race_ends_when_only_absent_humans_are_left(live: LiveServer, client: httpx.Client, driver: str) -> None:
    race = start_race(client, track="oval", laps=1, karts=[HUMAN, {"controller": "lane-follower"}])
    wait_status(client, race["id"], ("waiting",), 60)
    url = f"{live.ws_url}/api/races/{race['id']}/drive?kart=0&token={race['drive_tokens']['0']}"
    with connect(url, open_timeout=10) as ws:
        ws.recv(timeout=10)  # the race starts with its driver here...
        if driver == "silent":  # ...who then sends nothing (the page reads on) while the lane follower finishes
            while json.loads(ws.recv(timeout=120))["type"] != "end":
                pass
            ended = wait_status(client, race["id"], ("finished", "stopped", "aborted"), 120)
    if driver == "gone":  # ...or leaves at once
        ended = wait_status(client, race["id"], ("finished", "stopped", "aborted"), 120)
    assert ended["status"] == "finished"
    result = client.get(f"/api/races/{race['id']}/result").json()
    human, follower = result["karts"]
    assert follower["finished"] and not human["finished"]  # the human is recorded as not finished
    assert result["end_reason"].startswith(f"no unfinished kart could move for {STUCK_S:g} s: kart(s) 0 ")
    assert result["winner"] == 1
