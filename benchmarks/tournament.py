"""Tournament throughput: a sample of the paper's grid (every pairing of the five agents on ``oval`` and
``complex``, ``--races`` full-length races per pairing and track; start lanes alternating) run in worker
processes as ``karting tournament run`` does, replays recorded; the 1,000-race grid (50 per pairing and track)
projected from it.

* ``races_per_minute``: races finished per wall minute in the sample;
* ``realtime_factor``: simulated race-seconds per wall-second in the sample;
* ``full_grid_minutes``: each pairing and track's mean race wall time (drivers built, race run, replay kept) x 50,
  summed and divided among the workers: the grid's wall time on this machine when the workers stay busy.

Run from the repo root: ``.venv/bin/python benchmarks/tournament.py`` (about 2-3 minutes on 2 cores; ``--help``: the
sample, and ``--laps`` / ``--time-limit`` for short races, which the projection then assumes too). The last line
printed is one JSON object.
"""

from __future__ import annotations

import json
import statistics
import time
from collections import defaultdict

import typer

from arena.tournament import MemoryStore, TournamentSpec, default_workers, run_tournament

PAPER_AGENTS = "mcts-rl,e2e,fixed-rl,mcts-lqng,fixed-lqng"
GRID_RACES_PER_PAIR = 50

app = typer.Typer(add_completion=False)


@app.command()
def main(
    agents: str = typer.Option(PAPER_AGENTS, help="agents, comma separated"),
    tracks: str = typer.Option("oval,complex", help="tracks, comma separated"),
    races: int = typer.Option(1, min=1, help="races per pairing and track in the sample"),
    workers: int = typer.Option(0, min=0, help="worker processes (0: one per CPU)"),
    seed: int = typer.Option(0),
    laps: int | None = typer.Option(None, min=1, help="laps per race (default: each track's)"),
    time_limit: float | None = typer.Option(None, min=1.0, help="[s] per race (default: the rules' limit)"),
) -> None:
    """Run the sample, print a line per pairing and track, then the JSON summary."""
    n_workers = workers or default_workers()
    spec = TournamentSpec(
        tuple(agents.split(",")), tuple(tracks.split(",")), races, seed, laps=laps, time_limit=time_limit
    ).validate()
    store = MemoryStore()
    started = time.perf_counter()
    run_tournament(spec, store, "bench", backend="process", workers=n_workers)
    wall = time.perf_counter() - started
    finished = list(store.races["bench"].values())
    per_cell: dict[tuple[str, tuple[str, ...]], list[float]] = defaultdict(list)
    for race in finished:
        per_cell[(race.job.track, race.job.agents)].append(race.wall_seconds)
    for (track, pair), seconds in sorted(per_cell.items()):
        print(f"{track:8s} {' vs '.join(pair):26s} {statistics.fmean(seconds):6.1f} s/race ({len(seconds)} raced)")
    simulated = sum(race.result.duration for race in finished)
    grid_seconds = sum(statistics.fmean(s) * GRID_RACES_PER_PAIR for s in per_cell.values()) / n_workers
    summary = {
        "races": len(finished),
        "workers": n_workers,
        "wall_s": round(wall, 1),
        "races_per_minute": round(len(finished) / (wall / 60.0), 2),
        "realtime_factor": round(simulated / wall, 2),
        "full_grid_minutes": round(grid_seconds / 60.0, 1),
        "full_grid_races": len(per_cell) * GRID_RACES_PER_PAIR,
        "finished_share": round(sum(k.finished for r in finished for k in r.result.karts) / (2 * len(finished)), 3),
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    app()
