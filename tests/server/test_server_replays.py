"""Stored races through the real server with 3D views on: a race's viewer_url moves from the live view to the
replay player once it is over, /viewer/ redirects there, the replay scene opens on demand (bounded: 503 when
every allowed replay is watched), /api/races/{id}/report agrees with the result, and unknown or unfinished
races get clear answers."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
import viser
from support.live_server import LiveServer, server_settings, start_race, wait_for, wait_status
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

RACE = {"track": "oval", "laps": 1, "karts": [{"controller": "lane-follower"}, {"controller": "fixed-lqng"}]}
SUBPROTOCOL = Subprotocol(f"viser-v{viser.__version__}")
KINDS = {
    "collision_at_fault": "collisions_at_fault",
    "illegal_lane_change": "illegal_lane_changes",
    "wall_hit": "wall_hits",
    "pass": "passes",
}


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("replays") / "karting.db"
    settings = server_settings(db, viewer_enabled=True, speedup=20.0, keep_finished_s=1.0, max_replays=1)
    with LiveServer(settings) as server:
        yield server


@pytest.fixture(scope="module")
def client(live: LiveServer) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


@pytest.fixture(scope="module")
def races(client: httpx.Client) -> list[dict[str, Any]]:
    """Two finished one-lap races (seeds 1 and 2), as created; the second under drawn conditions, the lane
    follower handicapped."""
    paced = {**RACE, "karts": [{"controller": "lane-follower", "pace": 0.95}, {"controller": "fixed-lqng"}]}
    created = [
        start_race(client, **RACE, seed=1),
        start_race(client, **paced, seed=2, conditions="varied-equal-distance"),
    ]
    for race in created:
        wait_status(client, race["id"], ("finished",), 120)
    return created


def _viewer_socket(live: LiveServer, path: str) -> ClientConnection:
    return connect(f"{live.ws_url}{path}", subprotocols=[SUBPROTOCOL], open_timeout=10, max_size=None)


def _wait_for_status(client: httpx.Client, path: str, status: int) -> httpx.Response:
    """GET ``path`` until it answers ``status`` (the server notices a websocket's end within moments)."""
    answered: list[httpx.Response] = []

    def answers() -> bool:
        answered.append(client.get(path))
        return answered[-1].status_code == status

    wait_for(answers, 10.0, 0.1)
    return answered[-1]


def test_viewer_url_is_the_live_view_then_the_replay(races: list[dict[str, Any]], client: httpx.Client) -> None:
    race_id = races[0]["id"]
    assert races[0]["viewer_url"] == f"/races/{race_id}/viewer/"
    detail = client.get(f"/api/races/{race_id}").json()
    assert detail["viewer_url"] == f"/races/{race_id}/replay/"
    assert detail["page_url"] == f"/races/{race_id}" and detail["report_url"] == f"/api/races/{race_id}/report"
    viewer = client.get(f"/races/{race_id}/viewer/", follow_redirects=False)
    assert viewer.status_code == 307 and viewer.headers["location"] == f"/races/{race_id}/replay/"
    assert client.get(f"/races/{race_id}").status_code == 200  # the race page


def test_the_report_agrees_with_the_result(races: list[dict[str, Any]], client: httpx.Client) -> None:
    race_id = races[0]["id"]
    result = client.get(f"/api/races/{race_id}/result").json()
    report = client.get(f"/api/races/{race_id}/report").json()
    assert report["pose_error"] == 0.0 and report["laps"] == 1 and report["sector_ends"] == [8, 16, 24]
    counted = Counter((i["kart"], i["kind"]) for i in report["incidents"])
    for kart in result["karts"]:
        figures = report["karts"][kart["index"]]
        assert figures["index"] == kart["index"]
        if kart["finished"]:
            (lap,) = figures["laps"]
            assert lap["end_time"] == pytest.approx(kart["finish_time"]) and lap["time"] == lap["end_time"]
            assert sum(lap["sectors"]) == pytest.approx(lap["time"])
            assert lap["position"] == kart["position"]
        for kind, field in KINDS.items():
            assert counted[kart["index"], kind] == kart[field], kind
        assert len(figures["speed_by_lap"]) == 1 and len(figures["speed_by_lap"][0]) == len(report["distance_bins"])
        assert len(figures["wear"]) == len(report["wear_times"])


def test_a_race_under_drawn_conditions_and_a_handicap_is_re_simulated_as_it_ran(
    races: list[dict[str, Any]], client: httpx.Client
) -> None:
    race_id = races[1]["id"]
    result = client.get(f"/api/races/{race_id}/result").json()
    report = client.get(f"/api/races/{race_id}/report").json()
    assert report["pose_error"] == 0.0
    finished = [k for k in result["karts"] if k["finished"]]
    assert finished, "nobody finished: the finish times would not be compared"
    for kart in finished:
        assert sum(lap["time"] for lap in report["karts"][kart["index"]]["laps"]) == pytest.approx(
            kart["finish_time"], abs=2e-3
        )


def test_the_replay_scene_opens_on_demand_and_is_bounded(
    races: list[dict[str, Any]], client: httpx.Client, live: LiveServer
) -> None:
    first, second = (race["id"] for race in races)
    page = client.get(f"/races/{first}/replay/")
    assert page.status_code == 200 and b"/assets/replay-viewer.js" in page.content
    with _viewer_socket(live, f"/races/{first}/replay") as ws:
        assert isinstance(ws.recv(timeout=10), bytes)  # viser's scene messages
        # the one replay scene allowed is being watched: another race's replay must wait
        busy = client.get(f"/races/{second}/replay/")
        assert busy.status_code == 503 and "being watched" in busy.text
    # nobody watches the first one any more: it makes way
    ok = _wait_for_status(client, f"/races/{second}/replay/", 200)
    assert b"/assets/replay-viewer.js" in ok.content


def test_unknown_and_unfinished_races_are_told_so(client: httpx.Client, live: LiveServer) -> None:
    assert client.get("/races/nosuchrace/replay/").status_code == 404
    assert client.get("/api/races/nosuchrace/report").status_code == 404
    with _viewer_socket(live, "/races/nosuchrace/replay") as ws, pytest.raises(ConnectionClosed) as closed:
        ws.recv(timeout=10)
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 4404
    # a race waiting for its human driver is not over: no report, no replay, its viewer is the live one
    waiting = start_race(client, track="oval", laps=1, karts=[{"controller": "human"}, {"controller": "lane-follower"}])
    wait_status(client, waiting["id"], ("waiting",), 60)
    report = client.get(f"/api/races/{waiting['id']}/report")
    assert report.status_code == 409 and "no result yet" in report.json()["detail"]
    assert client.get(f"/races/{waiting['id']}/replay/").status_code == 404
    assert client.get(f"/api/races/{waiting['id']}").json()["viewer_url"] == f"/races/{waiting['id']}/viewer/"
    client.post(f"/api/races/{waiting['id']}/stop")
