"""Tournament throughput: a sample of the paper's grid (every pairing of the five agents on ``oval`` and
``complex``, ``--races`` full-length races per pairing and track; start lanes alternating) run in worker processes as
``karting tournament run`` does, replays recorded, through the batched runner (chunks of ``--batch`` races) and,
side by side in the same run, the per-race runner (chunks of one race); the 1,000-race grid projected from each.

* ``full_grid_minutes``: the batched sample's racing time (its wall time less ``worker_start_s``) x (50 /
  ``--races``), plus one worker start: the grid's wall time on this machine, every pairing and track weighing alike
  (as in the grid), its workers started once; ``full_grid_minutes_per_race_runner`` the same for the per-race
  runner, and ``batched_speedup`` their ratio;
* ``races_per_minute``, ``realtime_factor`` (simulated race-seconds per wall-second): of the batched sample;
* ``kart_steps_per_s_fixed_line``: kart-steps per wall-second per worker of a tournament of the fixed-line agents
  alone (``fixed-lqng``, ``fixed-rl``, ``lane-follower``; batched; ``--fixed-races`` races per pairing and track,
  ``fixed_line_races`` in all), and ``..._realtime_per_core`` the same over real time (50 kart-steps a second);
  ``worker_start_s``, the wall time of a tournament of one 1 s race of ``fixed-lqng`` and ``lane-follower``: what
  any tournament spends starting its worker processes before it races;
* ``outside_kernels_share``: the share of a one-process profile of the batched sample's first chunk spent outside
  the compiled kernels (numba's dispatchers: the search, the LQ game, the simulator) and the policy's matrix
  products: Python glue, the part batching and compiling can still remove.

A warm-up tournament of the sample's pairings (one 2 s race each) runs first, untimed: it compiles any kernel
numba's disk cache lacks, so that no timed run pays for compiling. Run from the repo root:
``.venv/bin/python benchmarks/tournament.py`` (a few minutes on 2 cores; ``--help``: the sample, ``--conditions``
(``paper`` for the paper's grid), ``--laps`` / ``--time-limit`` for short races, which the projection then assumes
too). The last line printed is one JSON object.
"""

from __future__ import annotations

import cProfile
import json
import pstats
import sys
import time
from dataclasses import replace

import typer

from arena.race import run_jobs
from arena.tournament import BATCH_RACES, MemoryStore, TournamentSpec, default_workers, run_tournament

PAPER_AGENTS = "mcts-rl,e2e,fixed-rl,mcts-lqng,fixed-lqng"
FIXED_LINE_AGENTS = ("fixed-lqng", "fixed-rl", "lane-follower")
GRID_RACES_PER_PAIR = 50
SIM_HZ = 50.0

app = typer.Typer(add_completion=False)


def _timed(spec: TournamentSpec, workers: int, batch: int) -> tuple[float, MemoryStore]:
    store = MemoryStore()
    started = time.perf_counter()
    run_tournament(spec, store, "bench", backend="process", workers=workers, batch=batch)
    return time.perf_counter() - started, store


def kernel_sites() -> set[tuple[str, int, str]]:
    """(file, line, name) of every numba kernel the project has loaded: how a profile names a call into one."""
    from numba.core.dispatcher import Dispatcher

    sites = set()
    for module in list(sys.modules.values()):
        if getattr(module, "__name__", "").startswith(("sim_core", "controllers")):
            for value in vars(module).values():
                if isinstance(value, Dispatcher):
                    code = value.py_func.__code__
                    sites.add((code.co_filename, code.co_firstlineno, code.co_name))
    return sites


def outside_kernels_share(spec: TournamentSpec, batch: int) -> float:
    """The share of a profile of the first ``batch`` races (in this process, through the batched runner) spent
    outside numba's compiled kernels (the search, the LQ game, the simulator, the RL observation and actions)."""
    profile = cProfile.Profile()
    profile.enable()
    run_jobs(spec.jobs()[:batch], record=True)
    profile.disable()
    stats = pstats.Stats(profile).stats  # type: ignore[attr-defined]
    sites = kernel_sites()
    total = sum(entry[2] for entry in stats.values())
    compiled = sum(entry[2] for site, entry in stats.items() if site in sites)
    return 1.0 - compiled / total


@app.command()
def main(
    agents: str = typer.Option(PAPER_AGENTS, help="agents, comma separated"),
    tracks: str = typer.Option("oval,complex", help="tracks, comma separated"),
    races: int = typer.Option(1, min=1, help="races per pairing and track in the sample"),
    workers: int = typer.Option(0, min=0, help="worker processes (0: one per CPU)"),
    batch: int = typer.Option(BATCH_RACES, min=1, help="races per chunk of the batched runner"),
    seed: int = typer.Option(0),
    laps: int | None = typer.Option(None, min=1, help="laps per race (default: each track's)"),
    time_limit: float | None = typer.Option(None, min=1.0, help="[s] per race (default: the rules' limit)"),
    per_race: bool = typer.Option(True, help="also run the sample through the per-race runner, for the ratio"),
    fixed_races: int = typer.Option(4, min=1, help="races per pairing and track in the fixed-line tournament"),
    conditions: str = typer.Option("varied", help="the condition set raced under (tournaments' default: varied)"),
) -> None:
    """Run the sample (batched, then per race), the fixed-line tournament and the profile; print the JSON."""
    n_workers = workers or default_workers()
    spec = TournamentSpec(
        tuple(agents.split(",")),
        tuple(tracks.split(",")),
        races,
        seed,
        laps=laps,
        time_limit=time_limit,
        conditions=conditions,
    ).validate()
    # every kernel the sample needs compiled and in numba's disk cache first: with a stale cache (sources edited
    # since), whichever run came first compiled them in each worker and measured slower (batched 0.44x per race)
    _timed(replace(spec, races_per_pair=1, time_limit=2.0), n_workers, batch)
    start = TournamentSpec(("fixed-lqng", "lane-follower"), spec.tracks[:1], 1, seed, time_limit=1.0)
    worker_start = _timed(start, n_workers, batch)[0]
    wall, store = _timed(spec, n_workers, batch)
    finished = list(store.races["bench"].values())

    def grid_minutes(sample_wall: float) -> float:
        return round((max(sample_wall - worker_start, 0.0) * GRID_RACES_PER_PAIR / races + worker_start) / 60.0, 1)

    simulated = sum(race.result.duration for race in finished)
    summary: dict[str, object] = {
        "races": len(finished),
        "workers": n_workers,
        "batch": batch,
        "wall_s": round(wall, 1),
        "races_per_minute": round(len(finished) / (wall / 60.0), 2),
        "realtime_factor": round(simulated / wall, 2),
        "full_grid_minutes": grid_minutes(wall),
        "full_grid_races": len(spec.tracks) * len(spec.pairs()) * GRID_RACES_PER_PAIR,
        "finished_share": round(sum(k.finished for r in finished for k in r.result.karts) / (2 * len(finished)), 3),
    }
    print(f"batched runner: {len(finished)} races in {wall:.1f} s")
    if per_race:
        alone_wall, _ = _timed(spec, n_workers, 1)
        print(f"per-race runner: {len(finished)} races in {alone_wall:.1f} s")
        summary["full_grid_minutes_per_race_runner"] = grid_minutes(alone_wall)
        summary["batched_speedup"] = round(alone_wall / wall, 2)
    fixed = replace(spec, agents=FIXED_LINE_AGENTS, races_per_pair=fixed_races)
    fixed_wall, fixed_store = _timed(fixed, n_workers, batch)
    kart_steps = sum(r.result.duration * SIM_HZ * len(r.job.agents) for r in fixed_store.races["bench"].values())
    per_core = kart_steps / fixed_wall / n_workers
    summary["fixed_line_races"] = fixed.total
    summary["kart_steps_per_s_fixed_line"] = round(per_core)
    summary["kart_steps_per_s_fixed_line_realtime_per_core"] = round(per_core / SIM_HZ, 1)
    summary["worker_start_s"] = round(worker_start, 2)
    summary["outside_kernels_share"] = round(outside_kernels_share(spec, min(batch, spec.total)), 3)
    print(json.dumps(summary))


if __name__ == "__main__":
    app()
