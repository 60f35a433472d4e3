"""A short series of mcts-lqng with ``rollout_check_depth`` against fixed-lqng as registered (or ``--opponent``), as
``scripts/head_to_head.py`` runs the issue's series (seeds 0..N-1, or from ``--first-seed``; kart 0 from lane 2 on
even seeds, lane 3 on odd ones), N races, W at a time. One JSON line per race, then a summary line.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session26/checked_series.py --track complex --races 10 \
        --depth 3 --workers 2
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller


def race(args: tuple[str, int, int, str]) -> dict[str, object]:
    track, seed, depth, opponent = args
    lanes = (2, 3) if seed % 2 == 0 else (3, 2)
    spec = RaceSpec(track=track, controllers=("mcts-lqng", opponent), seed=seed, start_lanes=lanes)
    drivers = [make_controller("mcts-lqng", rollout_check_depth=depth), make_controller(opponent)]
    outcome = run_race(spec, drivers=drivers)
    karts = outcome.result.karts
    return {
        "seed": seed,
        "lanes": lanes,
        "winner": outcome.result.winner,
        "time": [k.finish_time for k in karts],
        "faults": [k.collisions_at_fault for k in karts],
        "illegal": [k.illegal_lane_changes for k in karts],
        "passes": [k.passes for k in karts],
        "wall_s": round(outcome.wall_seconds, 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--track", default="complex")
    ap.add_argument("--races", type=int, default=10)
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--first-seed", type=int, default=0, help="seeds first-seed .. first-seed + races - 1")
    ap.add_argument("--opponent", default="fixed-lqng", help="the other kart's registered controller")
    args = ap.parse_args()
    jobs = [
        (args.track, seed, args.depth, args.opponent) for seed in range(args.first_seed, args.first_seed + args.races)
    ]
    rows = []
    with ProcessPoolExecutor(args.workers) as pool:
        for row in pool.map(race, jobs):
            rows.append(row)
            print(json.dumps(row), flush=True)
    n = len(rows)
    by_lane = {lane: [r for r in rows if r["lanes"][0] == lane] for lane in (2, 3)}  # type: ignore[index]
    summary = {
        "track": args.track,
        "opponent": args.opponent,
        "races": n,
        "depth": args.depth,
        "wins": sum(r["winner"] == 0 for r in rows),
        "wins_by_start_lane": {str(lane): sum(r["winner"] == 0 for r in rs) for lane, rs in by_lane.items()},
        "faults_per_race": [sum(r["faults"][k] for r in rows) / n for k in (0, 1)],  # type: ignore[index]
        "illegal_per_race": [sum(r["illegal"][k] for r in rows) / n for k in (0, 1)],  # type: ignore[index]
        "passes_per_race": [sum(r["passes"][k] for r in rows) / n for k in (0, 1)],  # type: ignore[index]
        "mean_time": [sum(r["time"][k] for r in rows) / n for k in (0, 1)],  # type: ignore[index,misc]
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
