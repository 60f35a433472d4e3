"""The web pages through the real server (``create_app`` under uvicorn, 3D views off): a page of a race or a
tournament that does not exist answers 404 with a page that says so, and one that exists answers 200; the race
page's start lanes are the lanes the karts started in, asked for or not, live and stored."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from support.live_server import LiveServer, server_settings, start_race, wait_for, wait_status

from arena.tournament import TournamentSpec
from server.db import RaceDatabase
from server.tournament_db import TournamentDatabase

WAITING_RACE = {"track": "oval", "laps": 1, "karts": [{"controller": "human"}, {"controller": "lane-follower"}]}
AI_RACE = {"track": "oval", "laps": 1, "karts": [{"controller": "lane-follower"}] * 3}


@pytest.fixture(scope="module")
def db_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("pages") / "karting.db"


@pytest.fixture(scope="module")
def client(db_path: Path) -> Iterator[httpx.Client]:
    # a race over is dropped from memory at once: its page then shows what the database stored
    settings = server_settings(db_path, controller_hosts=0, human_wait_s=600.0, keep_finished_s=0.2)
    with LiveServer(settings) as server, server.client() as c:
        yield c


@pytest.fixture(scope="module")
def tournament_id(db_path: Path, client: httpx.Client) -> str:
    """A tournament stored in the server's database (none of its races run)."""
    db = RaceDatabase(f"sqlite:///{db_path}")
    try:
        TournamentDatabase(db).create("t-pages", TournamentSpec(("lane-follower", "fixed-lqng"), ("oval",), 1))
    finally:
        db.close()
    assert client.get("/api/tournaments/t-pages").status_code == 200
    return "t-pages"


def test_the_page_of_an_unknown_race_is_not_found(client: httpx.Client) -> None:
    assert client.get("/api/races/UNKNOWN").status_code == 404
    page = client.get("/races/UNKNOWN")
    # the race page all the same: its script says "There is no race UNKNOWN."
    assert page.status_code == 404 and "/assets/race.js" in page.text
    assert page.headers["content-type"].startswith("text/html")
    for path in ("/races/UNKNOWN/viewer/", "/races/UNKNOWN/drive?kart=0&token=t"):
        missing = client.get(path)
        assert missing.status_code == 404 and "No race <code>UNKNOWN</code>" in missing.text, path
    replay = client.get("/races/UNKNOWN/replay/")
    assert replay.status_code == 404 and "No replay" in replay.text
    for path in ("/races/UNKNOWN/viewer", "/races/UNKNOWN/replay"):  # redirects to the pages above
        assert client.get(path, follow_redirects=True).status_code == 404, path
    assert client.get("/assets/UNKNOWN.js").status_code == 404


def test_the_page_of_an_unknown_tournament_is_not_found(client: httpx.Client, tournament_id: str) -> None:
    assert client.get("/api/tournaments/UNKNOWN").status_code == 404
    page = client.get("/tournaments/UNKNOWN")
    # the tournament page all the same: its script says "No tournament UNKNOWN."
    assert page.status_code == 404 and "/assets/tournament.js" in page.text
    known = client.get(f"/tournaments/{tournament_id}")
    assert known.status_code == 200 and known.text == page.text
    assert client.get("/tournaments").status_code == 200


def test_the_pages_of_a_race_that_exists_are_found(client: httpx.Client) -> None:
    race = start_race(client, **WAITING_RACE)
    try:
        page = client.get(f"/races/{race['id']}")
        assert page.status_code == 200 and "/assets/race.js" in page.text
        assert page.text == client.get("/races/UNKNOWN").text  # the same page, found
        assert client.get(race["karts"][0]["drive_url"]).status_code == 200
    finally:
        client.post(f"/api/races/{race['id']}/stop")


@pytest.mark.parametrize(("asked", "used"), [(None, [2, 3, 1]), ([3, 1, 4], [3, 1, 4])])
def test_the_race_shows_the_start_lanes_used(client: httpx.Client, asked: list[int] | None, used: list[int]) -> None:
    race = start_race(client, **AI_RACE, start_lanes=asked)
    live = wait_status(client, race["id"], ("running", "finished"), 60)
    assert live["start_lanes"] == used  # (race.js shows race.start_lanes)
    wait_status(client, race["id"], ("finished",), 120)
    result = client.get(f"/api/races/{race['id']}/result").json()
    assert result["start_lanes"] == used

    # once the server dropped the race from memory (its ticks' raw jitter goes with it), from the database
    wait_for(lambda: client.get(f"/api/races/{race['id']}/ticks").json()["recent_jitter_ms"] == [], 10)
    assert client.get(f"/api/races/{race['id']}").json()["start_lanes"] == used
