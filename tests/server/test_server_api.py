"""The race server's REST API and telemetry through a real uvicorn server: listings, validation (422), unknown
ids (404), an AI race to the finish with its result and replay, stopping, and results surviving a restart."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from support.live_server import LiveServer, server_settings, start_race, wait_status
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from controllers.registry import controller_names
from server.db import RaceDatabase, StoredRace, utc_now
from sim_core.params import DT
from web.frame import KartFrame, RaceFrame

ROOT = Path(__file__).resolve().parents[2]
SHORT_RACE = {"track": "oval", "laps": 1, "karts": [{"controller": "lane-follower"}, {"controller": "fixed-lqng"}]}


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("server") / "karting.db"
    with LiveServer(server_settings(db)) as server:
        yield server


@pytest.fixture(scope="module")
def client(live: LiveServer) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


@pytest.fixture(scope="module")
def finished_race(live: LiveServer, client: httpx.Client) -> dict[str, Any]:
    """A short AI race run to the finish while a telemetry client records every message."""
    race = start_race(client, **SHORT_RACE, seed=3)
    messages = []
    with connect(f"{live.ws_url}{race['telemetry_url']}", open_timeout=10) as ws:
        try:
            while True:
                messages.append(json.loads(ws.recv(timeout=60)))
        except ConnectionClosed as closed:
            close_code = closed.rcvd.code if closed.rcvd is not None else None
    return {"race": race, "telemetry": messages, "close_code": close_code}


def test_tracks_list_every_builtin_track_both_ways(client: httpx.Client) -> None:
    tracks = {t["name"]: t for t in client.get("/api/tracks").json()}
    assert {"oval", "complex", "oval-reversed", "complex-reversed"} <= set(tracks)
    oval = tracks["oval"]
    assert oval["n_checkpoints"] == 24 and oval["laps"] == 4 and oval["lane_change_limit"] == 3
    assert 280 < oval["length_m"] < 300


def test_controllers_list_the_registry_and_human(client: httpx.Client) -> None:
    controllers = {c["name"]: c for c in client.get("/api/controllers").json()}
    assert set(controllers) == {*controller_names(), "human"}
    assert controllers["mcts-lqng"]["parameters"]["iterations"] == "2000"
    assert all(c["description"] for c in controllers.values())


@pytest.mark.parametrize(
    ("change", "where", "says"),
    [
        ({"track": "monza"}, ["body", "track"], "unknown track 'monza'"),
        (
            {"karts": [{"controller": "lane-follower"}, {"controller": "schumacher"}]},
            ["body", "karts", 1, "controller"],
            "unknown controller 'schumacher'",
        ),
        ({"laps": 0}, ["body", "laps"], "greater than or equal to 1"),
        ({"laps": 500}, ["body", "laps"], "laps must be in 1..20"),
        ({"karts": [{"controller": "lane-follower"}] * 9}, ["body", "karts"], "at most 8"),
        ({"karts": []}, ["body", "karts"], "at least 1"),
        ({"start_lanes": [1, 2, 3]}, ["body", "start_lanes"], "one start lane per kart"),
        ({"start_lanes": [1, 7]}, ["body", "start_lanes", 1], "less than or equal to 4"),
        ({"seed": -1}, ["body", "seed"], "greater than or equal to 0"),
        ({"seed": "abc"}, ["body", "seed"], "valid integer"),
        ({"kart_preset": "rocket"}, ["body", "kart_preset"], "'paper' or 'original'"),
        ({"colour": "red"}, ["body", "colour"], "Extra inputs are not permitted"),
        (
            {"karts": [{"controller": "lane-follower", "name": "x" * 33}]},
            ["body", "karts", 0, "name"],
            "at most 32 characters",
        ),
        (
            {"karts": [{"controller": "lane-follower", "name": "Ann"}, {"controller": "fixed-lqng", "name": "ann "}]},
            ["body", "karts", 1, "name"],
            "kart 1 is already called 'Ann'",
        ),
        (
            {"karts": [{"controller": "lane-follower"}, {"controller": "fixed-lqng", "name": "lane-follower 1"}]},
            ["body", "karts", 1, "name"],
            "already called 'lane-follower 1'",
        ),
    ],
)
def test_bad_race_requests_get_422_saying_what_is_wrong(
    client: httpx.Client, change: dict[str, Any], where: list[Any], says: str
) -> None:
    response = client.post("/api/races", json={**SHORT_RACE, **change})
    assert response.status_code == 422
    errors = response.json()["detail"]
    assert any(e["loc"] == where and says in e["msg"] for e in errors), errors


def test_the_limits_are_the_ones_the_api_enforces(client: httpx.Client) -> None:
    """GET /api/limits (what the start page's form allows) against what POST /api/races accepts."""
    limits = client.get("/api/limits").json()
    assert limits["min_laps"] == 1 and limits["max_laps"] == 20  # Settings.max_laps
    assert (limits["min_karts"], limits["max_karts"]) == (1, 8) and limits["max_name_length"] == 32
    too_many = {**SHORT_RACE, "karts": [{"controller": "lane-follower"}] * (limits["max_karts"] + 1)}
    too_long = {**SHORT_RACE, "karts": [{"controller": "lane-follower", "name": "n" * (limits["max_name_length"] + 1)}]}
    for body in (too_many, too_long, {**SHORT_RACE, "laps": limits["max_laps"] + 1}, {**SHORT_RACE, "laps": 0}):
        assert client.post("/api/races", json=body).status_code == 422, body
    assert limits["default_name"] == "{controller} {number}"


def test_unknown_race_ids_get_404(client: httpx.Client) -> None:
    for method, path in [
        ("GET", "/api/races/nosuchrace"),
        ("GET", "/api/races/nosuchrace/result"),
        ("GET", "/api/races/nosuchrace/replay"),
        ("GET", "/api/races/nosuchrace/ticks"),
        ("POST", "/api/races/nosuchrace/stop"),
    ]:
        response = client.request(method, path)
        assert response.status_code == 404, (method, path, response.text)
        assert "nosuchrace" in response.json()["detail"]


def test_unknown_race_telemetry_closes_with_4404(live: LiveServer) -> None:
    with (
        connect(f"{live.ws_url}/api/races/nosuchrace/telemetry", open_timeout=10) as ws,
        pytest.raises(ConnectionClosed) as closed,
    ):
        ws.recv(timeout=10)
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 4404


def test_ai_race_runs_to_the_finish_and_stores_its_result(finished_race: dict[str, Any], client: httpx.Client) -> None:
    race = finished_race["race"]
    assert race["viewer_url"] is None and race["drive_tokens"] == {}
    assert [k["controller"] for k in race["karts"]] == ["lane-follower", "fixed-lqng"]
    detail = client.get(f"/api/races/{race['id']}").json()
    assert detail["status"] == "finished"
    stats = detail["tick_stats"]
    assert stats["ticks"] > 0 and stats["period_ms"] == pytest.approx(2.0)  # speedup 10
    result = client.get(f"/api/races/{race['id']}/result").json()
    assert result["status"] == "finished" and result["laps"] == 1
    karts = result["karts"]
    assert sorted(k["position"] for k in karts) == [1, 2]
    assert all(k["finished"] and k["laps"] == 1 and k["finish_time"] > 10 for k in karts)
    winner = min(karts, key=lambda k: k["finish_time"])
    assert result["winner"] == winner["index"] and [k["winner"] for k in karts].count(True) == 1
    for k in karts:
        assert k["safety_score"] == k["collisions_at_fault"] + k["illegal_lane_changes"]
        assert {"delta_r", "delta_v", "wall_hits", "controller_faults"} <= set(k)
    assert karts[1]["delta_r"] is not None  # fixed-lqng's plans became the referee's targets
    # what the race was started with, default names numbered from 1, lap times, times to the millisecond
    assert (result["seed"], result["kart_preset"], result["start_lanes"]) == (3, "paper", [2, 3])
    assert [k["name"] for k in karts] == ["lane-follower 1", "fixed-lqng 2"]
    for k in karts:
        assert len(k["lap_times"]) == 1 and k["lap_times"][0] == pytest.approx(k["finish_time"], abs=0.002)
        assert k["finish_time"] == round(k["finish_time"], 3) and result["duration"] == round(result["duration"], 3)
    listed = {r["id"]: r for r in client.get("/api/races").json()}
    assert listed[race["id"]]["status"] == "finished"
    assert [s["index"] for s in listed[race["id"]]["standings"]] == [winner["index"], 1 - winner["index"]]


def test_replay_has_every_step_and_the_plans(finished_race: dict[str, Any], client: httpx.Client) -> None:
    race_id = finished_race["race"]["id"]
    replay = client.get(f"/api/races/{race_id}/replay").json()
    result = client.get(f"/api/races/{race_id}/result").json()
    assert replay["track"] == "oval" and replay["dt"] == DT
    assert len(replay["poses"]) == round(result["duration"] / DT)
    assert all(len(step) == 2 and all(len(pose) == 6 for pose in step) for step in replay["poses"])
    x0, y0 = replay["poses"][0][0][:2]
    x1, y1 = replay["poses"][-1][0][:2]
    assert (x1 - x0) ** 2 + (y1 - y0) ** 2 > 1.0  # the karts went somewhere
    assert replay["plans"] and all(p["kart"] == 1 for p in replay["plans"])  # only fixed-lqng plans
    assert "waypoints" in replay["plans"][0]["plan"]


def test_telemetry_streams_frames_then_the_result(finished_race: dict[str, Any]) -> None:
    messages = finished_race["telemetry"]
    frames = [m for m in messages if m["type"] == "frame"]
    assert len(frames) > 20
    assert set(frames[-1]) == {"type", *RaceFrame.__dataclass_fields__}
    assert set(frames[-1]["karts"][0]) == set(KartFrame.__dataclass_fields__)
    steps = [f["step"] for f in frames if f["status"] == "running"]
    assert steps == sorted(steps) and steps[-1] > steps[0]
    assert any(f["karts"][1]["waypoints"] for f in frames)  # fixed-lqng's plan is drawn
    finished = [k for f in frames for k in f["karts"] if k["finished"]]
    assert finished and not any(k["waypoints"] or k["predicted"] for k in finished)  # until it finished
    assert frames[-1]["status"] == "finished"
    assert messages[-1]["type"] == "result" and messages[-1]["result"]["status"] == "finished"
    assert finished_race["close_code"] == 1000


def test_result_is_409_while_running_and_stop_ends_the_race(client: httpx.Client) -> None:
    race = start_race(client, **{**SHORT_RACE, "laps": 5})
    wait_status(client, race["id"], ("running",), 30)
    response = client.get(f"/api/races/{race['id']}/result")
    assert response.status_code == 409 and "running" in response.json()["detail"]
    assert client.get(f"/api/races/{race['id']}/replay").status_code == 409
    stopped = client.post(f"/api/races/{race['id']}/stop")
    assert stopped.status_code == 200 and stopped.json()["status"] == "stopped"
    result = client.get(f"/api/races/{race['id']}/result").json()
    assert result["status"] == "stopped" and not any(k["finished"] for k in result["karts"])
    assert client.post(f"/api/races/{race['id']}/stop").status_code == 409


def test_results_survive_a_restart_and_dead_races_are_aborted(tmp_path: Path) -> None:
    db = tmp_path / "karting.db"
    with LiveServer(server_settings(db, speedup=20.0)) as first, first.client() as c:
        race = start_race(c, **SHORT_RACE)
        wait_status(c, race["id"], ("finished",), 60)
        result = c.get(f"/api/races/{race['id']}/result").json()
        replay = c.get(f"/api/races/{race['id']}/replay").json()
        unfinished = start_race(c, **{**SHORT_RACE, "laps": 5})
        wait_status(c, unfinished["id"], ("running",), 30)
    # a race a crashed server left "running" in the database
    crashed = RaceDatabase(f"sqlite:///{db}")
    crashed.add(StoredRace("deadbeef0000", utc_now(), "running", "oval", 1, 0, "paper", [], None, None, None, None))
    crashed.close()
    with LiveServer(server_settings(db, max_sessions=1)) as second, second.client() as c:
        listed = {r["id"]: r for r in c.get("/api/races").json()}
        assert listed[race["id"]]["status"] == "finished"
        assert listed[unfinished["id"]]["status"] == "aborted"  # the server stopped under it
        assert listed["deadbeef0000"]["status"] == "aborted"  # marked on startup
        assert c.get(f"/api/races/{race['id']}/result").json() == result
        assert c.get(f"/api/races/{race['id']}/replay").json() == replay
        assert c.get(f"/api/races/{race['id']}").json()["tick_stats"]["ticks"] > 0
        assert c.get("/api/races/deadbeef0000/result").status_code == 409
        with connect(f"{second.ws_url}/api/races/{race['id']}/telemetry", open_timeout=10) as ws:
            assert json.loads(ws.recv(timeout=10))["result"] == result
        # max_sessions=1: a second live race is refused
        start_race(c, **{**SHORT_RACE, "laps": 5})
        refused = c.post("/api/races", json=SHORT_RACE)
        assert refused.status_code == 429 and "races are running" in refused.json()["detail"]


def test_the_drive_client_example_runs_as_written(live: LiveServer) -> None:
    done = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "04_drive_client.py"), "--url", live.url, "--laps", "1"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr
    assert "race finished" in done.stdout and "drive_client.py" in done.stdout


def test_a_live_team_race_gives_every_planner_its_karts_teams(client: httpx.Client) -> None:
    """Karts with a ``team`` race together: the race keeps each kart's team, and each driver's context numbers
    the teams (a kart without one alone in its own); a blank team is a 422 naming it."""
    from controllers.base import team_numbers
    from server.race_config import KartEntry, RaceConfig, driver_context
    from sim_core.track_io import get_track
    from sim_core.world import World

    karts = [
        {"controller": "lane-follower", "team": "blue"},
        {"controller": "lane-follower", "team": "red"},
        {"controller": "lane-follower", "team": "blue"},
        {"controller": "lane-follower"},
    ]
    race = start_race(client, track="oval", laps=1, karts=karts)
    assert [k["team"] for k in race["karts"]] == ["blue", "red", "blue", None]
    assert [k["team"] for k in client.get(f"/api/races/{race['id']}").json()["karts"]] == ["blue", "red", "blue", None]
    client.post(f"/api/races/{race['id']}/stop")
    assert team_numbers(["blue", "red", "blue", None]) == (1, 2, 1, 3) and team_numbers([None, None]) == ()
    entries = tuple(KartEntry(i, f"k{i}", "lane-follower", team=k.get("team")) for i, k in enumerate(karts))
    track = get_track("oval")
    config = RaceConfig("oval", track, 1, 0, None, "paper", entries)
    assert driver_context(config, World(track, 1, 4), 2).teams == (1, 2, 1, 3)
    blank = client.post("/api/races", json={"track": "oval", "karts": [{"controller": "e2e", "team": " "}] * 2})
    assert blank.status_code == 422 and any(e["loc"][-1] == "team" for e in blank.json()["detail"])
