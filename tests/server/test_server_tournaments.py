"""Tournaments through the real server (uvicorn, the app's lifespan, a temporary SQLite file): a reduced grid
started by POST runs in the background with live progress, its races are ordinary stored races (result, replay),
its statistics have the documented shape; bad agent or track names are 422 entries saying what was wrong."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from support.live_server import LiveServer, server_settings, wait_for

SMALL = {
    "agents": ["fixed-lqng", "lane-follower"],
    "tracks": ["oval"],
    "races_per_pair": 2,
    "laps": 1,
    "time_limit": 30.0,
    "seed": 5,
    "id": "api-small",
}


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[httpx.Client]:
    db = tmp_path_factory.mktemp("tournaments") / "karting.db"
    with LiveServer(server_settings(db, tournament_workers=1)) as server, server.client() as c:
        yield c


@pytest.mark.parametrize(
    ("change", "where", "says"),
    [
        ({"agents": ["fixed-lqng", "schumacher"]}, ["body", "agents"], "unknown agents ['schumacher']"),
        ({"tracks": ["monza"]}, ["body", "tracks"], "unknown tracks ['monza']"),
        ({"agents": ["e2e", "e2e"]}, ["body", "agents"], "two or more different agents"),
        ({"agents": ["e2e", "fixed-lqng:line_margin_m=9"]}, ["body", "agents"], "'line_margin_m' = 9.0 is above"),
        ({"agents": ["e2e", "fixed-lqng:pace=1"]}, ["body", "agents"], "'pace' is unknown"),
        ({"agents": ["e2e", "fixed-lqng:fast"]}, ["body", "agents"], "'fast' is not KEY=VALUE"),
        ({"races_per_pair": 0}, ["body", "races_per_pair"], "greater than or equal to 1"),
        ({"races_per_pair": True}, ["body", "races_per_pair"], "must be a number, not a boolean"),
        ({"agents": ["e2e", "fixed-lqng@0.2"]}, ["body", "agents"], "pace must be in [0.5, 1]"),
        ({"id": "bad id!"}, ["body", "id"], "should match pattern"),
        (
            {"conditions": "wet"},
            ["body", "conditions"],
            "Input should be 'paper', 'varied', 'varied-pace' or 'varied-equal-distance'",
        ),
        ({"team_size": 3}, ["body", "team_size"], "less than or equal to 2"),
        ({"team_size": 2, "races_per_pair": 3}, ["body", "races_per_pair"], "mirrored pairs"),
    ],
)
def test_bad_tournaments_are_422_saying_what_was_wrong(
    client: httpx.Client, change: dict[str, Any], where: list[Any], says: str
) -> None:
    response = client.post("/api/tournaments", json={**SMALL, **change})
    assert response.status_code == 422, response.text
    errors = response.json()["detail"]
    assert any(e["loc"] == where and says in e["msg"] for e in errors), errors


def test_a_reduced_grid_runs_in_the_background_with_progress_and_stored_races(client: httpx.Client) -> None:
    started = client.post("/api/tournaments", json=SMALL)
    assert started.status_code == 202, started.text
    body = started.json()
    assert body["id"] == "api-small" and body["total"] == 2 and body["status"] == "running"
    seen: list[int] = []

    def finished() -> dict[str, Any] | None:
        tournament: dict[str, Any] = client.get(body["url"]).json()
        seen.append(tournament["done"])
        return tournament if tournament["status"] == "finished" else None

    tournament = wait_for(finished, 180, 0.2)
    assert tournament["done"] == 2 and tournament["progress"] == 1.0 and not tournament["running"]
    assert seen == sorted(seen)  # progress only grows
    races = tournament["races"]
    assert [r["index"] for r in races] == [0, 1] and [r["start_lanes"] for r in races] == [[2, 3], [3, 2]]
    for race in races:
        assert client.get(race["url"]).json()["status"] == "finished"
        result = client.get(race["result_url"])
        assert result.status_code == 200 and len(result.json()["karts"]) == 2
        replay = client.get(race["replay_url"])
        assert replay.status_code == 200 and replay.json()["track"] == "oval"
    stats = client.get(tournament["stats_url"]).json()
    assert stats == tournament["stats"]
    assert set(stats["tracks"]) == {"oval", "combined"}
    oval = stats["tracks"]["oval"]
    assert set(oval) == {"wins", "safety", "start_lanes", "tests"}
    assert oval["safety"]["fixed-lqng"]["races"] == 2
    assert oval["start_lanes"]["races"] == 2 and set(oval["start_lanes"]["by_lane"]) == {"2", "3"}
    assert {"per_step", "checkpoint", "rule"} <= set(oval["safety"]["fixed-lqng"]["illegal_lane_changes"])
    listed = client.get("/api/tournaments").json()
    assert "api-small" in [t["id"] for t in listed] and all(t["races"] is None for t in listed)


def test_an_id_taken_by_other_settings_is_a_conflict_and_unknown_ids_404(client: httpx.Client) -> None:
    assert client.get("/api/tournaments/nope").status_code == 404
    assert client.get("/api/tournaments/nope/stats").status_code == 404
    assert client.post("/api/tournaments/nope/stop").status_code == 404
    one = {**SMALL, "races_per_pair": 1, "id": "api-one"}
    assert client.post("/api/tournaments", json=one).status_code == 202
    wait_for(lambda: client.get("/api/tournaments/api-one").json()["status"] == "finished", 180, 0.2)
    response = client.post("/api/tournaments", json={**one, "races_per_pair": 3})
    assert response.status_code == 409 and "another spec" in response.json()["detail"]
    assert client.post("/api/tournaments/api-one/stop").status_code == 409  # not running
    again = client.post("/api/tournaments", json=one)  # the same settings: resumes, with nothing left to run
    assert again.status_code == 202 and again.json()["done"] == 1
