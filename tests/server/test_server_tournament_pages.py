"""The endpoints behind the tournament pages, on races stored by hand (no simulation): the leaderboard across
stored tournaments against numbers worked out by hand, the report tables laid out like the paper's, the PNG
plots (drawn once per number of races stored, 404 for unknown plots or tournaments), the light poll
(``?stats=false``) and the id the leaderboard's address reserves.

The app is the API router alone under uvicorn, with the tournament runner and plot cache its lifespan would set\nup.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from fastapi import FastAPI
from support.live_server import ServerThread

from arena.intervals import wilson
from arena.race import FinishedRace
from arena.tournament import TournamentSpec
from server.db import RaceDatabase
from server.routes import api_router
from server.tournament_db import TournamentDatabase, TournamentStatus
from server.tournament_plots import TournamentPlots
from server.tournaments import TournamentRunner
from sim_core.world import KartResult, RaceResult

PNG = b"\x89PNG\r\n\x1a\n"


def kart(index: int, time: float | None, collisions: int = 0, illegal: int = 0, position: int = 1) -> KartResult:
    """A kart's referee result: finished when ``time`` is given; ``illegal`` lane changes under both rules."""
    return KartResult(
        kart=index,
        finished=time is not None,
        finish_time=time,
        laps_completed=1 if time is not None else 0,
        checkpoints_passed=10,
        collisions_at_fault=collisions,
        illegal_lane_changes=illegal,
        safety_score=collisions + illegal,
        wall_hits=0,
        contacts=collisions,
        buffer_violations=0,
        delta_r=None,
        delta_v=None,
        position=position,
        illegal_lane_changes_per_step=illegal,
        illegal_lane_changes_checkpoint=illegal,
    )


def store_tournament(
    store: TournamentDatabase, tournament_id: str, agents: tuple[str, str], per_pair: int, results: list[RaceResult]
) -> None:
    """A tournament on the oval whose first races ended with ``results`` (kart 0 is ``agents[0]``)."""
    spec = TournamentSpec(agents, ("oval",), per_pair, seed=3, laps=1, time_limit=60.0)
    store.create(tournament_id, spec)
    for job, result in zip(spec.jobs(), results, strict=False):
        store.save(tournament_id, FinishedRace(job, result, 1, 0.5, None))
    done = len(results) == spec.total
    store.set_status(tournament_id, TournamentStatus.FINISHED if done else TournamentStatus.STOPPED)


@pytest.fixture()
def app(tmp_path: Path) -> Iterator[FastAPI]:
    db = RaceDatabase(f"sqlite:///{tmp_path / 'karting.db'}")
    store = TournamentDatabase(db)
    # t1: fixed-lqng wins (80 s against 85 s), then does not finish and lane-follower wins
    store_tournament(
        store,
        "t1",
        ("fixed-lqng", "lane-follower"),
        2,
        [
            RaceResult((kart(0, 80.0, collisions=1), kart(1, 85.0, illegal=2, position=2)), 0, 85.0, True),
            RaceResult((kart(0, None, position=2), kart(1, 90.0, collisions=1)), 1, 90.0, True),
        ],
    )
    # t2: nobody finishes; mcts-lqng is at fault three times
    store_tournament(
        store,
        "t2",
        ("mcts-lqng", "fixed-lqng"),
        1,
        [RaceResult((kart(0, None, collisions=3), kart(1, None, position=2)), None, 60.0, True)],
    )
    store_tournament(store, "t3", ("fixed-lqng", "mcts-lqng"), 1, [])  # no race yet
    app = FastAPI()
    app.include_router(api_router)
    app.state.tournaments = TournamentRunner(store, workers=1, max_running=1)
    app.state.tournament_plots = TournamentPlots()
    yield app
    db.close()


@pytest.fixture()
def client(app: FastAPI) -> Iterator[httpx.Client]:
    with ServerThread(app, lifespan="off") as server, server.client() as c:
        yield c


def test_the_leaderboard_ranks_agents_over_every_stored_tournament(client: httpx.Client) -> None:
    response = client.get("/api/tournaments/leaderboard")
    assert response.status_code == 200, response.text
    board = response.json()
    assert (board["tournaments"], board["races"]) == (2, 3)  # t3 has no race
    rows = {s["agent"]: s for s in board["agents"]}
    assert [s["agent"] for s in board["agents"]] == ["lane-follower", "fixed-lqng", "mcts-lqng"]  # win rate
    # lane-follower: t1 only; won race 1; finished both; safety 0 + 2 = 2 and 1 + 0 = 1
    lane = rows["lane-follower"]
    assert (lane["tournaments"], lane["races"], lane["wins"], lane["finished"]) == (1, 2, 1, 2)
    assert lane["win_rate"] == 0.5 and lane["safety_score_mean"] == 1.5 and lane["safety_score_std"] == 0.5
    # fixed-lqng: t1 and t2; won race 0 of t1 only; finished that one only; safety 1, 0, 0
    fixed = rows["fixed-lqng"]
    assert (fixed["tournaments"], fixed["races"], fixed["wins"], fixed["finished"]) == (2, 3, 1, 1)
    assert fixed["win_rate"] == pytest.approx(1 / 3)
    assert fixed["safety_score_mean"] == pytest.approx(1 / 3)
    assert fixed["safety_score_std"] == pytest.approx(math.sqrt(2 / 9))  # population std of (1, 0, 0)
    # mcts-lqng: one race, nobody won, three collisions at fault
    mcts = rows["mcts-lqng"]
    assert (mcts["tournaments"], mcts["races"], mcts["wins"], mcts["finished"], mcts["win_rate"]) == (1, 1, 0, 0, 0)
    assert (mcts["safety_score_mean"], mcts["safety_score_std"]) == (3.0, 0.0)


def test_an_empty_leaderboard(tmp_path: Path) -> None:
    db = RaceDatabase(f"sqlite:///{tmp_path / 'empty.db'}")
    app = FastAPI()
    app.include_router(api_router)
    app.state.tournaments = TournamentRunner(TournamentDatabase(db), workers=1, max_running=1)
    with ServerThread(app, lifespan="off") as server, server.client() as client:
        assert client.get("/api/tournaments/leaderboard").json() == {"tournaments": 0, "races": 0, "agents": []}
    db.close()


def test_the_tables_are_laid_out_like_the_papers(client: httpx.Client) -> None:
    response = client.get("/api/tournaments/t1/tables")
    assert response.status_code == 200, response.text
    tables = response.json()
    assert (tables["done"], tables["total"]) == (2, 2) and list(tables["tracks"]) == ["oval", "combined"]
    oval = tables["tracks"]["oval"]
    assert oval["wins"] == [
        ["agent", "vs fixed-lqng", "vs lane-follower"],
        ["fixed-lqng", "-", "1"],
        ["lane-follower", "1", "-"],
    ]
    assert oval["safety"][0][:3] == ["agent", "avg. collisions-at-fault", "std. dev. collisions-at-fault"]
    assert oval["safety"][2][0] == "lane-follower" and oval["safety"][2][-2:] == ["2", "2"]  # finished, races
    # race 0: fixed-lqng from lane 2 won; race 1: lane-follower from lane 2 won (Fisher's p of [[1, 0], [0, 1]])
    assert oval["start_lanes"] == [
        ["pair", "from lane 2: wins–losses", "from lane 3: wins–losses", "Fisher p"],
        ["fixed-lqng vs lane-follower", "1–0", "0–1", "1"],
        ["any kart", "2–0", "0–2", "-"],
    ]
    # one race each: a 50% win rate with its Wilson interval for 1 of 2, and two different races
    interval = wilson(1, 2)
    assert interval is not None
    rate = f"50% [{100 * interval.low:.0f}, {100 * interval.high:.0f}]"
    assert oval["pairs"][1] == ["fixed-lqng vs lane-follower", "2", rate, "2", "1 of 1 / 0 of 1", "1"]
    assert tables["ratings"][0] == ["rank", "agent", "rating θ [95% CI]", "races"]
    assert sorted(row[1] for row in tables["ratings"][1:]) == ["fixed-lqng", "lane-follower"]
    names = [p["name"] for p in tables["plots"]]
    assert names == ["wins_oval", "safety_oval", "wins_combined", "safety_combined", "finish_times"]
    assert all(p["url"].startswith(f"/api/tournaments/t1/plots/{p['name']}.png") for p in tables["plots"])
    assert client.get("/api/tournaments/t3/tables").status_code == 409
    assert client.get("/api/tournaments/nope/tables").status_code == 404


def test_plots_are_pngs_drawn_once_and_unknown_ones_404(client: httpx.Client, app: FastAPI) -> None:
    plots: TournamentPlots = app.state.tournament_plots
    urls = [p["url"] for p in client.get("/api/tournaments/t1/tables").json()["plots"]]
    first = [client.get(url) for url in urls]
    for response in first:
        assert response.status_code == 200 and response.headers["content-type"] == "image/png"
        assert response.content.startswith(PNG) and len(response.content) > 5_000
    assert plots.drawn == 1  # every plot of a tournament is drawn at once
    again = client.get("/api/tournaments/t1/plots/wins_oval.png")
    assert again.content == first[0].content and plots.drawn == 1  # cached
    missing = client.get("/api/tournaments/t1/plots/nope.png")
    assert missing.status_code == 404 and "wins_oval" in missing.json()["detail"]
    assert client.get("/api/tournaments/t1/plots/wins_oval.svg").status_code == 404
    assert client.get("/api/tournaments/nope/plots/wins_oval.png").status_code == 404
    assert client.get("/api/tournaments/t3/plots/wins_oval.png").status_code == 409  # no race yet
    assert client.get("/api/tournaments/t2/plots/finish_times.png").status_code == 200
    assert plots.drawn == 2


def test_the_light_poll_leaves_the_statistics_out(client: httpx.Client) -> None:
    full = client.get("/api/tournaments/t1").json()
    light = client.get("/api/tournaments/t1", params={"stats": "false"}).json()
    assert full["stats"] is not None and light["stats"] is None
    assert light["races"] == full["races"] and (light["done"], light["status"]) == (2, "finished")


def test_the_leaderboards_address_is_no_tournament_id(client: httpx.Client) -> None:
    body = {"agents": ["fixed-lqng", "lane-follower"], "tracks": ["oval"], "id": "leaderboard"}
    response = client.post("/api/tournaments", json=body)
    assert response.status_code == 422
    assert any(e["loc"] == ["body", "id"] and "reserved" in e["msg"] for e in response.json()["detail"])
