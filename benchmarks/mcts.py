"""MCTS tactical planner speed on the real game: 2 players, horizon 8, on `oval` and `complex`, as raced by
``mcts-lqng`` (segment times calibrated on the racing line, the other kart a modelled line follower).

Prints iterations/s of a 20,000-iteration search and the wall time of a 2,000-iteration plan (the full
planner call: root construction, search, waypoint extraction), and the same plan in a field: the ego among
``--field`` karts (default 8: two rows of four, the second a checkpoint behind, every other kart a modelled line
follower). The last line is one JSON object with `iterations_per_s` (the slower track), `plan_2000_ms` (the
slower track, median of 5) and `plan_2000_ms_field` (likewise, with the field), against the live budget.
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
from server.settings import Settings
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track

PLAN_BUDGET_MS = 1000.0 * Settings.model_fields["plan_budget_s"].default  # the live server's, for one plan


def field_players(checkpoint: int, karts: int) -> list[PlayerState]:
    """The ego (kart 0) on pole of a field of ``karts``: rows of four in lanes 2, 3, 1, 4, each row a checkpoint
    behind the one before and 0.15 s later, every other kart a modelled line follower."""
    lanes = (2, 3, 1, 4)
    return [
        PlayerState(
            kart=k,
            checkpoint=checkpoint - k // 4,
            lane=lanes[k % 4],
            speed=11.0 + 0.25 * (k % 4),
            time=20.0 + 0.15 * (k // 4) + 0.05 * (k % 4),
            wear=0.3,
            lane_changes=0,
            model=rules.MODEL_LINE if k else rules.MODEL_FREE,
        )
        for k in range(karts)
    ]


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
    parser.add_argument("--field", type=int, default=8, help="karts of the field plan timed (2-8)")
    args = parser.parse_args()
    rates: dict[str, float] = {}
    plan_ms: dict[str, float] = {}
    field_ms: dict[str, float] = {}
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
        times = []
        for i in range(5):
            small.reset()
            t0 = time.perf_counter()
            small.plan(field_players(3 + i, args.field), 0)
            times.append((time.perf_counter() - t0) * 1000)
        field_ms[name] = statistics.median(times)
        print(
            f"{name}: {rates[name]:,.0f} iterations/s; {args.plan_iterations:,}-iteration plan "
            f"{plan_ms[name]:.1f} ms, in a field of {args.field} {field_ms[name]:.1f} ms (medians of 5)"
        )
    print(
        json.dumps(
            {
                "iterations_per_s": round(min(rates.values())),
                "plan_2000_ms": round(max(plan_ms.values()), 2),
                "iterations_per_s_per_track": {k: round(v) for k, v in rates.items()},
                "plan_2000_ms_per_track": {k: round(v, 2) for k, v in plan_ms.items()},
                "plan_2000_ms_field": round(max(field_ms.values()), 2),
                "plan_2000_ms_field_per_track": {k: round(v, 2) for k, v in field_ms.items()},
                "field_karts": args.field,
                # the budgets run: plan_2000_ms keeps its name, and is the 2,000-iteration plan at the defaults
                "iterations": {"search": args.iterations, "plan": args.plan_iterations},
                # the field plan within the live server's plan budget
                "targets": {"iterations_per_s": 50000, "plan_2000_ms": 40, "plan_2000_ms_field": PLAN_BUDGET_MS},
            }
        )
    )


if __name__ == "__main__":
    main()
