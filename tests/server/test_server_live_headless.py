"""Live as headless: a live race in a lockstep server (each tick waits for the controllers' answers and the plans
due) is the headless race of the same seed, step for step: the same plans applied at the same race times (a plan
takes effect its latency after it was asked for, live as headless), the same inputs from the grid on, the same
poses in the replay and the same result, at ten times real time on a loaded machine."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import numpy as np
import pytest
from support.live_server import LiveServer, server_settings, start_race, wait_status

from controllers.race import RaceSpec, run_race

SEED = 3


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[httpx.Client]:
    db = tmp_path_factory.mktemp("live-headless") / "karting.db"
    with LiveServer(server_settings(db, speedup=10.0, countdown_s=0.0, lockstep=True)) as server, server.client() as c:
        yield c


@pytest.mark.parametrize(
    ("agents", "conditions"), [(("mcts-lqng", "fixed-lqng"), "paper"), (("mcts-rl", "e2e"), "varied")]
)
def test_a_lockstep_live_race_is_the_headless_race_of_its_seed(
    client: httpx.Client, agents: tuple[str, str], conditions: str
) -> None:
    karts = [{"controller": a} for a in agents]
    race = start_race(client, track="oval", laps=1, seed=SEED, conditions=conditions, karts=karts)
    wait_status(client, race["id"], ("finished",), 180)
    live = client.get(f"/api/races/{race['id']}/result").json()["karts"]
    poses = np.asarray(client.get(f"/api/races/{race['id']}/replay").json()["poses"])
    headless = run_race(
        RaceSpec(track="oval", controllers=agents, laps=1, seed=SEED, conditions=conditions), record=True
    )
    assert headless.replay is not None
    assert [k["missed_deadlines"] for k in live] == [0, 0]
    assert np.array_equal(poses, np.asarray(headless.replay.as_dict()["poses"]))
    for mine, theirs in zip(live, headless.result.karts, strict=True):
        assert mine["finish_time"] == pytest.approx(theirs.finish_time, abs=5e-4)  # stored to the millisecond
        assert mine["position"] == theirs.position and mine["passes"] == theirs.passes
