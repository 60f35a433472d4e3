"""Tournaments: the schedule (pairs, alternating start lanes, seeds), a reduced grid in worker processes equal to
the same grid run inline, on a local Ray, every race stored with its result and replay in the server's
database, and a runner killed part way (SIGKILL) that resumes to the same results without losing a race."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from arena.stats import tournament_stats
from arena.tournament import MemoryStore, TournamentSpec, run_tournament
from server.db import RaceDatabase
from server.tournament_db import TournamentDatabase, TournamentStatus, race_id

ROOT = Path(__file__).resolve().parents[2]
# a reduced grid: one pair, one track, one lap, a short time limit (a race takes well under a second)
SMALL = TournamentSpec(
    agents=("fixed-lqng", "lane-follower"), tracks=("oval",), races_per_pair=2, laps=1, time_limit=30.0, seed=7
)


def comparable(races: list) -> list:  # type: ignore[type-arg]
    """Everything a race's figures hold (the replay and wall time aside)."""
    return [json.dumps(r.__dict__, default=lambda o: getattr(o, "__dict__", str(o)), sort_keys=True) for r in races]


def test_the_schedule_covers_every_pair_on_every_track_with_alternating_lanes_and_fixed_seeds() -> None:
    spec = TournamentSpec(agents=("a", "b", "c"), tracks=("oval", "complex"), races_per_pair=4, seed=1)
    jobs = spec.jobs()
    assert len(jobs) == spec.total == 2 * 3 * 4 and [j.index for j in jobs] == list(range(24))
    assert {(j.track, j.agents) for j in jobs} == {
        (t, p) for t in ("oval", "complex") for p in (("a", "b"), ("a", "c"), ("b", "c"))
    }
    assert [j.start_lanes for j in jobs[:4]] == [(2, 3), (3, 2), (2, 3), (3, 2)]
    assert [j.seed for j in jobs] == [j.seed for j in spec.jobs()]  # reproducible
    # a paired design: race r of every pair on a track shares its seed; different races and tracks do not
    assert len({j.seed for j in jobs}) == 8
    assert len({(j.track, j.seed) for j in jobs}) == 8 and {j.seed for j in jobs[:4]} == {j.seed for j in jobs[4:8]}
    assert [j.seed for j in TournamentSpec(("a", "b", "c"), ("oval", "complex"), 4, seed=2).jobs()] != [
        j.seed for j in jobs
    ]


def test_a_spec_names_every_problem() -> None:
    problems = TournamentSpec(agents=("fixed-lqng", "schumacher"), tracks=("monza",), races_per_pair=0).problems()
    assert "schumacher" in problems["agents"] and "monza" in problems["tracks"] and "races_per_pair" in problems
    assert "two or more" in TournamentSpec(agents=("e2e", "e2e")).problems()["agents"]
    with pytest.raises(ValueError, match="schumacher"):
        TournamentSpec(agents=("fixed-lqng", "schumacher")).validate()
    assert TournamentSpec.from_json(json.loads(json.dumps(SMALL.to_json()))) == SMALL
    assert "conditions" in TournamentSpec(agents=("fixed-lqng", "e2e"), conditions="wet").problems()


def test_an_agent_with_parameters_races_as_its_own_agent_with_them() -> None:
    """``fixed-lqng@0.7`` is fixed-lqng driving a kart at a pace handicap of 0.7: a different agent in the
    tournament, which the same controller at full pace beats on the line from either start lane."""
    slow = "fixed-lqng@0.7"
    spec = TournamentSpec(agents=("fixed-lqng", slow), tracks=("oval",), races_per_pair=2, laps=1, seed=3)
    assert spec.problems() == {}
    store = MemoryStore()
    run_tournament(spec, store, "variants", backend="inline", record=False)
    races = list(store.races["variants"].values())
    assert len(races) == 2 and {r.job.agents for r in races} == {("fixed-lqng", slow)}
    assert {r.job.start_lanes for r in races} == {(2, 3), (3, 2)}
    assert all(r.result.winner == 0 for r in races)
    wins = tournament_stats(store.figures("variants")).tracks["oval"].wins
    assert wins == {"fixed-lqng": {slow: 2}, slow: {"fixed-lqng": 0}}
    # the paper's E2E races with a planner in the background for its Δr and Δv: with parameters too
    variant = TournamentSpec(agents=("e2e:deterministic=false", "fixed-lqng"), tracks=("oval",), races_per_pair=1)
    assert variant.jobs()[0].background_planners == ("e2e:deterministic=false",)
    bad = TournamentSpec(agents=("fixed-lqng", "fixed-lqng:line_margin_m=0.1")).problems()["agents"]
    assert "'line_margin_m' = 0.1 is below its minimum 0.5" in bad
    slower = TournamentSpec(agents=("fixed-lqng", "fixed-lqng@0.1")).problems()["agents"]
    assert "pace must be in [0.5, 1], got 0.1" in slower


def test_the_conditions_reach_every_race_paired_across_pairs_and_old_specs_read_back_as_paper() -> None:
    spec = TournamentSpec(agents=("a", "b", "c"), tracks=("oval", "complex"), races_per_pair=3)
    assert spec.conditions == "varied"  # a tournament's default
    jobs = spec.jobs()
    assert all(j.conditions == "varied" and j.spec().conditions == "varied" for j in jobs)
    by_pair: dict[tuple[str, tuple[str, ...]], list[object]] = {}
    for job in jobs:
        by_pair.setdefault((job.track, job.agents), []).append(job.spec().drawn())
    oval = [drawn for (track, _), drawn in by_pair.items() if track == "oval"]
    assert len(oval) == 3 and oval[0] == oval[1] == oval[2]  # race r of every pair: the same conditions
    assert len(set(map(str, oval[0]))) == 3  # different races of a pair: different conditions
    complex_ = [drawn for (track, _), drawn in by_pair.items() if track == "complex"]
    assert complex_[0] != oval[0]
    stored_with_a_spread = {**SMALL.to_json(), "start_spread": 0.0}
    stored_with_a_spread.pop("conditions")
    assert TournamentSpec.from_json(stored_with_a_spread).conditions == "paper"


def test_a_reduced_grid_in_worker_processes_equals_the_same_grid_run_inline() -> None:
    inline, pooled = MemoryStore(), MemoryStore()
    assert run_tournament(SMALL, inline, "t", backend="inline") == 2
    assert run_tournament(SMALL, pooled, "t", backend="process", workers=2) == 2
    assert comparable(pooled.figures("t")) == comparable(inline.figures("t"))
    assert run_tournament(SMALL, pooled, "t", backend="process") == 0  # nothing left to run
    races = inline.figures("t")
    assert [r.start_lanes for r in races] == [(2, 3), (3, 2)]
    stats = tournament_stats(races).to_json()["tracks"]["oval"]
    wins = stats["wins"]
    assert wins["fixed-lqng"]["lane-follower"] + wins["lane-follower"]["fixed-lqng"] <= 2
    assert stats["safety"]["fixed-lqng"]["races"] == 2


def test_every_race_is_stored_in_the_servers_database_with_its_result_and_replay(tmp_path: Path) -> None:
    races = RaceDatabase(f"sqlite:///{tmp_path / 'karting.db'}")
    store = TournamentDatabase(races)
    store.create("small", SMALL)
    progress = []
    run_tournament(SMALL, store, "small", backend="inline", on_progress=lambda p: progress.append(p.done))
    assert progress == [0, 1, 2]
    stored = races.get(race_id("small", 1))
    assert stored is not None and stored.result is not None and stored.start_lanes == [3, 2]
    assert [k.controller for k in stored.karts] == ["fixed-lqng", "lane-follower"]
    replay = races.replay(race_id("small", 1))
    assert replay is not None and replay["track"] == "oval" and len(replay["poses"]) > 100
    tournament = store.get("small")
    assert tournament is not None and (tournament.done, tournament.total) == (2, 2)
    assert tournament.status == TournamentStatus.RUNNING
    assert [r.index for r in store.figures("small")] == [0, 1]
    with pytest.raises(ValueError, match="another spec"):
        store.create("small", TournamentSpec(agents=("fixed-lqng", "lane-follower")))
    with pytest.raises(ValueError, match="ids are"):
        store.create("no spaces", SMALL)


@pytest.mark.slow  # starts a local Ray
def test_the_ray_backend_runs_the_reduced_grid_on_a_local_ray() -> None:
    ray = pytest.importorskip("ray", reason="the ray backend needs the tournament extra (ray)")
    inline, on_ray = MemoryStore(), MemoryStore()
    run_tournament(SMALL, inline, "t", backend="inline")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        assert run_tournament(SMALL, on_ray, "t", backend="ray") == 2
    finally:
        ray.shutdown()
    assert comparable(on_ray.figures("t")) == comparable(inline.figures("t"))


def _run_cli(db: Path, tournament_id: str, races: int) -> subprocess.Popen[bytes]:
    args = [
        sys.executable,
        "-m",
        "karting",
        "tournament",
        "run",
        "--agents",
        "fixed-lqng,lane-follower",
        "--tracks",
        "oval",
        "--races-per-pair",
        str(races),
        "--laps",
        "1",
        "--time-limit",
        "30",
        "--seed",
        "3",
        "--workers",
        "1",
        "--db",
        str(db),
        "--id",
        tournament_id,
    ]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "200"}
    return subprocess.Popen(
        args, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True
    )


@pytest.mark.slow  # three runs of the command line, one killed
def test_a_tournament_killed_part_way_resumes_to_the_results_of_one_run_straight_through(tmp_path: Path) -> None:
    races = 8
    straight = _run_cli(tmp_path / "straight.db", "grid", races)
    assert straight.wait(300) == 0, straight.stderr.read().decode() if straight.stderr else ""

    killed_db = tmp_path / "killed.db"
    runner = _run_cli(killed_db, "grid", races)
    store = TournamentDatabase(RaceDatabase(f"sqlite:///{killed_db}"))
    give_up = time.monotonic() + 240
    while time.monotonic() < give_up and runner.poll() is None:
        if store.get("grid") is not None and len(store.finished_indices("grid")) >= 2:
            break
        time.sleep(0.02)
    assert runner.poll() is None, "the runner ended before it could be killed"
    os.killpg(runner.pid, signal.SIGKILL)  # the runner and its worker processes, mid-tournament
    runner.wait(30)
    before = {r.job.index: r for r in store.races("grid")}
    assert 2 <= len(before) < races
    assert store.get("grid").status == TournamentStatus.RUNNING  # type: ignore[union-attr]

    resumed = _run_cli(killed_db, "grid", races)
    assert resumed.wait(300) == 0, resumed.stderr.read().decode() if resumed.stderr else ""
    after = {r.job.index: r for r in store.races("grid")}
    assert sorted(after) == list(range(races))
    for index, race in before.items():  # no finished race lost or re-run
        assert after[index].record == race.record and after[index].wall_seconds == race.wall_seconds
    done = store.get("grid")
    assert done is not None and done.status == TournamentStatus.FINISHED and done.done == races

    reference = TournamentDatabase(RaceDatabase(f"sqlite:///{tmp_path / 'straight.db'}"))
    assert [r.record.to_json() for r in reference.races("grid")] == [r.record.to_json() for r in after.values()]
    assert tournament_stats(reference.figures("grid")).to_json() == tournament_stats(store.figures("grid")).to_json()
