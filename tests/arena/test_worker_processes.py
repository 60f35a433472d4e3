"""Tournament worker processes: one that dies loses only the race it was running, which runs again (the results
equal a run without the fault), a race that fails in its worker reports its own error, and none outlives a runner
killed with SIGKILL."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest
from support.processes import descendants, describe, survivors_after

from arena.race import RaceJob
from arena.tournament import MemoryStore, Progress, TournamentSpec, _process_races, run_tournament
from server.db import RaceDatabase
from server.tournament_db import TournamentDatabase
from sim_core.track_io import TrackFormatError

ROOT = Path(__file__).resolve().parents[2]
SPEC = TournamentSpec(
    agents=("fixed-lqng", "lane-follower"), tracks=("oval",), races_per_pair=6, laps=1, time_limit=30.0, seed=11
)
BATCH = 2  # races per chunk: 3 chunks for 2 workers, so one is still queued when the first is stored


def pool_workers() -> list[psutil.Process]:
    """This process's tournament workers: the processes the fork server (a child of this process) forked."""
    children = {p.pid for p in psutil.Process().children()}
    return [p for p in descendants(os.getpid()) if p.ppid() in children and "forkserver" in " ".join(p.cmdline())]


def test_a_worker_that_dies_loses_only_its_chunk_which_runs_again(caplog: pytest.LogCaptureFixture) -> None:
    reference = MemoryStore()
    run_tournament(SPEC, reference, "t", backend="inline")
    killed: list[int] = []
    # forked for other work of this process (a live server's planner workers of an earlier test): not ours
    others = {p.pid for p in pool_workers()}

    def kill_a_worker(progress: Progress) -> None:
        # the first race stored: the other worker is racing the second chunk, and the one that stored it may be
        # idle or already on the third (killing that one alone, idle, lost nothing now and then): kill both, so
        # the running chunk dies with its worker
        if progress.done == 1 and not killed:
            workers = [p for p in pool_workers() if p.pid not in others]
            assert workers, "no worker process found"
            for worker in workers:
                worker.kill()
                killed.append(worker.pid)

    store = MemoryStore()
    with caplog.at_level(logging.WARNING, logger="arena.tournament"):
        stored = run_tournament(SPEC, store, "t", backend="process", workers=2, on_progress=kill_a_worker, batch=BATCH)
    assert killed and stored == SPEC.total
    assert "their worker process died; running them again" in caplog.text
    assert [r.index for r in store.figures("t")] == list(range(SPEC.total))
    ours = [(r.index, r.karts, r.duration) for r in store.figures("t")]
    assert ours == [(r.index, r.karts, r.duration) for r in reference.figures("t")]


def test_a_race_that_fails_in_its_worker_reports_its_own_error() -> None:
    # not "its worker process died": the error is sent back whole (it must pickle) and ends the run at once
    job = RaceJob(index=0, track="no/such/track.json", agents=("lane-follower",), seed=0, start_lanes=(2,))
    with pytest.raises(TrackFormatError, match=r"^no/such/track\.json: "):
        list(_process_races([(job,)], workers=1, record=False))


def test_no_worker_outlives_a_killed_runner(tmp_path: Path) -> None:
    db = tmp_path / "karting.db"
    args = [sys.executable, "-m", "karting", "tournament", "run", "--agents", "fixed-lqng,lane-follower"]
    args += ["--tracks", "oval", "--races-per-pair", "40", "--laps", "1", "--seed", "5", "--workers", "2"]
    args += ["--db", str(db), "--id", "crash"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    runner = subprocess.Popen(args, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        store = TournamentDatabase(RaceDatabase(f"sqlite:///{db}"))
        give_up = time.monotonic() + 240
        while time.monotonic() < give_up and runner.poll() is None:
            if db.exists() and store.get("crash") is not None and store.finished_indices("crash"):
                break
            time.sleep(0.05)
        assert runner.poll() is None, "the runner ended before it could be killed"
        tree = descendants(runner.pid)
        assert len(tree) >= 3, describe(tree)  # the fork server, its workers, the resource tracker
        runner.send_signal(signal.SIGKILL)  # the runner only: its workers must follow by themselves
        runner.wait(10)
        left = survivors_after(tree, 5.0)
        assert not left, describe(left)
    finally:
        if runner.poll() is None:
            runner.kill()
