"""MCTS tactical planner speed on the real game: 2 players, horizon 8, on `oval` and `complex`, as raced by
``mcts-lqng`` (segment times calibrated on the racing line, the other kart a modelled line follower).

Prints iterations/s of a 20,000-iteration search and the wall time of a 2,000-iteration plan (the full
planner call: root construction, search, waypoint extraction). The last line is one JSON object with
`iterations_per_s` (the slower track) and `plan_2000_ms` (the slower track, median of 5).
Run from the repo root: ``.venv/bin/python benchmarks/mcts.py`` (``--help``: the budgets and tracks; the smoke test
runs it with tiny budgets, where the figures mean nothing).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

from controllers.racing_line import optimise_racing_line
from controllers.tactical import rules
from controllers.tactical.planner import PlayerState, TacticalPlanner
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track


def players(checkpoint: int) -> list[PlayerState]:
    return [
        PlayerState(kart=0, checkpoint=checkpoint, lane=2, speed=11.0, time=20.0, wear=0.3, lane_changes=0),
        PlayerState(
            kart=1,
            checkpoint=checkpoint,
            lane=3,
            speed=12.0,
            time=20.15,
            wear=0.3,
            lane_changes=1,
            model=rules.MODEL_LINE,
        ),
    ]


def main() -> None:
    """Time the long search and the short plans per track; print a line each, then the JSON summary."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=20_000, help="the search timed for iterations/s")
    parser.add_argument("--plan-iterations", type=int, default=2_000, help="the budget of the plans timed")
    parser.add_argument("--tracks", default="oval,complex", help="tracks, comma separated")
    args = parser.parse_args()
    rates: dict[str, float] = {}
    plan_ms: dict[str, float] = {}
    for name in args.tracks.split(","):
        track = get_track(name)
        line = optimise_racing_line(track, PAPER_KART)
        big = TacticalPlanner(track, PAPER_KART, iterations=args.iterations, seed=1, line=line)
        big.plan(players(2), 0)  # compile
        big.reset()
        t0 = time.perf_counter()
        plan = big.plan(players(2), 0)
        rates[name] = plan.iterations / (time.perf_counter() - t0)
        small = TacticalPlanner(track, PAPER_KART, iterations=args.plan_iterations, seed=1, line=line)
        times = []
        for i in range(5):
            small.reset()
            t0 = time.perf_counter()
            small.plan(players(2 + i), 0)
            times.append((time.perf_counter() - t0) * 1000)
        plan_ms[name] = statistics.median(times)
        print(
            f"{name}: {rates[name]:,.0f} iterations/s; {args.plan_iterations:,}-iteration plan "
            f"{plan_ms[name]:.1f} ms (median of 5)"
        )
    print(
        json.dumps(
            {
                "iterations_per_s": round(min(rates.values())),
                "plan_2000_ms": round(max(plan_ms.values()), 2),
                "iterations_per_s_per_track": {k: round(v) for k, v in rates.items()},
                "plan_2000_ms_per_track": {k: round(v, 2) for k, v in plan_ms.items()},
                # the budgets run: plan_2000_ms keeps its name, and is the 2,000-iteration plan at the defaults
                "iterations": {"search": args.iterations, "plan": args.plan_iterations},
                "targets": {"iterations_per_s": 50000, "plan_2000_ms": 40},
            }
        )
    )


if __name__ == "__main__":
    main()
