"""Decision time of every registered controller: the slowest and the median ``act`` call in a short race start.

Each controller drives kart 0 for 120 steps (2.4 s) on ``oval``, ``complex`` and ``train-oval-small-reversed``
beside a kart that only accelerates, as ``tests/controllers/test_registry.py`` does for its contract; the first call
(which may compile and plan) is not counted. A hierarchical driver plans in line here, so its slowest call
includes a re-plan. The budget is 0.5 s for any one decision (the live server gives a driver a deadline per
tick and moves planning to a worker; a headless race has only this). Timings depend on the machine and on what
else runs, which is why this is a benchmark and not a test.
Run from the repo root: ``.venv/bin/python benchmarks/decision_time.py`` (``--help``: steps, tracks, controllers).
The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

from controllers.base import RaceContext
from controllers.registry import controller_names, make_controller
from sim_core.observation import observe
from sim_core.params import SimParams
from sim_core.track_io import get_track
from sim_core.world import World

TRACKS = ("oval", "complex", "train-oval-small-reversed")
STEPS = 120
BUDGET_S = 0.5  # [s] for any one decision


def decision_times(name: str, track_name: str, steps: int = STEPS) -> list[float]:
    """Seconds per ``act`` call of controller ``name`` over ``steps`` steps, the first call left out."""
    track = get_track(track_name)
    world = World(track, 1, 2, SimParams())
    driver = make_controller(name)
    driver.reset(RaceContext(track, world.params.kart, 0, 2, world.lane_change_limit, seed=1))
    times = []
    for step in range(steps):
        obs = observe(world, 0)[0]
        t0 = time.perf_counter()
        action = driver.act(obs)
        if step > 0:  # the first call may compile and plan
            times.append(time.perf_counter() - t0)
        world.step(np.array([[[action.steer, action.throttle], [0.0, 0.5]]]))
    return times


def main() -> None:
    """Time every controller on every track; print a line per controller, then the JSON summary."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=STEPS, help="steps per controller and track (2 or more)")
    parser.add_argument("--tracks", default=",".join(TRACKS), help="tracks, comma separated")
    parser.add_argument("--controllers", default="", help="controllers, comma separated (default: every one)")
    args = parser.parse_args()
    names = args.controllers.split(",") if args.controllers else controller_names()
    slowest: dict[str, float] = {}
    median: dict[str, float] = {}
    for name in names:
        per_track = {track: decision_times(name, track, args.steps) for track in args.tracks.split(",")}
        slowest[name] = max(max(t) for t in per_track.values())
        median[name] = statistics.median(x for t in per_track.values() for x in t)
        print(f"{name}: slowest {slowest[name] * 1000:.1f} ms, median {median[name] * 1000:.3f} ms per decision")
    print(
        json.dumps(
            {
                "slowest_decision_ms": {k: round(v * 1000, 2) for k, v in slowest.items()},
                "median_decision_ms": {k: round(v * 1000, 4) for k, v in median.items()},
                "budget_ms": BUDGET_S * 1000,
                "within_budget": all(v < BUDGET_S for v in slowest.values()),
            }
        )
    )


if __name__ == "__main__":
    main()
