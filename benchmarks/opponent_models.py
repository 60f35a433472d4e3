"""Tactical plan time with measured opponent models, beside the racing-line model alone, in real races.

Races ``mcts-lqng-adaptive`` (every other kart played by the model that forecast it best, the forecasts made at
every plan: the best-response playouts included) and ``mcts-lqng`` (every other kart a racing-line follower)
as kart 0 of the same races, against one and against three other agents, and times every plan of kart 0
(the whole high-level call: forecasts, scoring, root, search, extraction; the race's first plan left out: it
compiles). Also the race start's cost of the simulated-agent models (each simulates a registered agent's lap
once per track and process).

The last line is one JSON object: ``plan_ms_p50`` and ``plan_ms_max`` (adaptive, the worst field),
``plan_ms_p50_racing_line``, ``reset_s_simulated`` and the per-field figures. Target: ``plan_ms_max`` <= 100.
Run from the repo root: ``.venv/bin/python benchmarks/opponent_models.py`` (``--laps``, ``--tracks``: the smoke
test runs a few seconds of race, where the figures mean little).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from controllers.race import RaceSpec, run_race
from controllers.registry import make_agent
from controllers.tactical.opponents import solo_lap_lanes
from sim_core.track_io import get_track

FIELDS = {"1v1": ("fixed-rl",), "4 karts": ("fixed-lqng", "e2e", "mcts-rl")}


def plan_times(ego: str, opponents: tuple[str, ...], track: str, laps: int, time_limit: float | None) -> list[float]:
    """[ms] every plan of kart 0 after its first, in one race of ``ego`` against ``opponents``."""
    drivers: list[Any] = [make_agent(name) for name in (ego, *opponents)]
    planner = drivers[0].planner
    timed: list[float] = []
    plan: Callable[..., Any] = planner.plan

    def timed_plan(observation: Any) -> Any:
        t0 = time.perf_counter()
        out = plan(observation)
        timed.append((time.perf_counter() - t0) * 1000.0)
        return out

    planner.plan = timed_plan
    spec = RaceSpec(track=track, controllers=(ego, *opponents), laps=laps, seed=3, time_limit=time_limit)
    run_race(spec, drivers=drivers)
    return timed[1:]


def main() -> None:
    """Race each field on each track with both planners; print a line per field, then the JSON summary."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tracks", default="oval,complex", help="tracks, comma separated")
    parser.add_argument("--laps", type=int, default=2)
    parser.add_argument("--time-limit", type=float, default=None, help="[s] cut each race short (smoke runs)")
    args = parser.parse_args()
    tracks = args.tracks.split(",")
    t0 = time.perf_counter()
    for track in tracks:
        for agent in ("fixed-lqng", "fixed-rl"):
            solo_lap_lanes(get_track(track), agent, make_agent)
    reset_s = (time.perf_counter() - t0) / len(tracks)
    figures: dict[str, dict[str, float]] = {}
    for field_name, opponents in FIELDS.items():
        for track in tracks:
            row = {}
            for ego in ("mcts-lqng-adaptive", "mcts-lqng"):
                times = np.array(plan_times(ego, opponents, track, args.laps, args.time_limit) or [0.0])
                row[f"{ego} p50"] = round(float(np.median(times)), 2)
                row[f"{ego} max"] = round(float(times.max()), 2)
            figures[f"{field_name} {track}"] = row
            print(f"{field_name} on {track}: {row}", flush=True)
    print(
        json.dumps(
            {
                "plan_ms_p50": max(r["mcts-lqng-adaptive p50"] for r in figures.values()),
                "plan_ms_max": max(r["mcts-lqng-adaptive max"] for r in figures.values()),
                "plan_ms_p50_racing_line": max(r["mcts-lqng p50"] for r in figures.values()),
                "reset_s_simulated": round(reset_s, 2),
                "per_field": figures,
                "targets": {"plan_ms_max": 100},
            }
        )
    )


if __name__ == "__main__":
    main()
