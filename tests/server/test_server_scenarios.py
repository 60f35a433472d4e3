"""Scenario runs through the real server: the shipped scenarios listed, a bad run a 422 naming the field and the
index, a small run started, finished in the background and stored with its figures."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import pytest
from support.live_server import LiveServer, server_settings, wait_for


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[httpx.Client]:
    db = tmp_path_factory.mktemp("scenarios") / "karting.db"
    with LiveServer(server_settings(db, tournament_workers=1)) as server, server.client() as c:
        yield c


def test_the_shipped_scenarios_are_listed(client: httpx.Client) -> None:
    listed = {s["name"]: s for s in client.get("/api/scenarios").json()}
    assert listed["overtake-straight"]["kind"] == "overtake" and listed["defend-straight"]["paces"] == [0.97]
    assert listed["lapping-straight"]["backmarker"] == "fixed-lqng" and listed["start-4-karts"]["karts"] == 4


@pytest.mark.parametrize(
    ("change", "loc", "says"),
    [
        ({"scenarios": ["drift"]}, ["body", "scenarios", 0], "unknown scenario 'drift'"),
        ({"egos": ["fixed-lqng", "schumacher"]}, ["body", "egos", 1], "unknown controller 'schumacher'"),
        ({"opponents": ["e2e@0.9"]}, ["body", "opponents", 0], "a scenario sets the pace"),
        ({"tracks": ["../etc/passwd"]}, ["body", "tracks", 0], "unknown track"),
        ({"paces": [0.2]}, ["body", "paces", 0], "greater than or equal to 0.5"),
        ({"opponents": ["fixed-lqng"]}, ["body", "opponents"], "0 cells"),
        ({"attempts": 0}, ["body", "attempts"], "greater than or equal to 1"),
        ({"seed": False}, ["body", "seed"], "must be a number, not a boolean"),
    ],
)
def test_a_bad_run_is_a_422_naming_what_was_wrong(
    client: httpx.Client, change: dict[str, object], loc: list[object], says: str
) -> None:
    body = {"scenarios": ["overtake-straight"], "egos": ["fixed-lqng"], "opponents": ["lane-follower"], **change}
    response = client.post("/api/scenarios/runs", json=body)
    assert response.status_code == 422, response.text
    detail = response.json()["detail"][0]
    assert detail["loc"] == loc and says in detail["msg"]


def test_a_run_finishes_in_the_background_with_its_figures(client: httpx.Client) -> None:
    body = {
        "scenarios": ["overtake-straight"],
        "egos": ["fixed-lqng"],
        "opponents": ["lane-follower"],
        "tracks": ["oval"],
        "paces": [0.8],
        "attempts": 2,
    }
    started = client.post("/api/scenarios/runs", json=body)
    assert started.status_code == 202, started.text
    url = started.json()["url"]
    run = wait_for(lambda: (r := client.get(url).json())["status"] != "running" and r, 180, 0.5)
    assert run["status"] == "finished", run
    (cell,) = run["summary"]["cells"]
    assert (cell["ego"], cell["opponent"], cell["pace"], cell["attempts"]) == ("fixed-lqng", "lane-follower", 0.8, 2)
    assert run["request"]["paces"] == [0.8]
    assert client.get("/api/scenarios/runs").json()[0]["id"] == run["id"]
    assert client.get("/api/scenarios/runs/nope").status_code == 404
