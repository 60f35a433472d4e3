"""The station-keeping sweep of session 21: mcts-lqng with tracker overrides (``NAME=VALUE`` arguments, floats,
on top of the shipped ``MCTS_TRACKING``) from a start lane of ``complex`` against fixed-lqng at each speed scale,
STARTS races each (seeds 0, 2, 4, ...). One JSON line per race, then a summary line.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session21/sweep/sweep.py complex 0.98,0.97,0.95,0.93 16 2,3 \\
        follow_safe_braking=6.0 follow_brake_gain=10.0 follow_time=0.05 follow_distance=2.3 follow_distance_curve=0.0
"""

from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller


def race(args: tuple[str, dict[str, float], float, int, tuple[int, int]]) -> dict[str, object]:
    """One race; the tracker overridden by ``changes``."""
    track, changes, scale, seed, lanes = args
    driver = make_controller("mcts-lqng")
    assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
    driver.tracker = LQNGTracker(replace(driver.tracker.params, **changes))  # type: ignore[arg-type]
    spec = RaceSpec(track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=seed, start_lanes=lanes)
    karts = run_race(spec, drivers=[driver, make_controller("fixed-lqng", speed_scale=scale)]).result.karts
    t = [k.finish_time if k.finish_time is not None else float("inf") for k in karts]
    return {
        "scale": scale,
        "seed": seed,
        "lanes": lanes,
        "won": t[0] < t[1],
        "margin": round(t[0] - t[1], 2),
        "passes": [k.passes for k in karts],
        "faults": [k.collisions_at_fault for k in karts],
        "illegal": [k.illegal_lane_changes for k in karts],
    }


def main() -> None:
    track, scales_arg, starts_arg, lanes_arg, *overrides = sys.argv[1:]
    scales = [float(x) for x in scales_arg.split(",")]
    starts = int(starts_arg)
    a, b = (int(x) for x in lanes_arg.split(","))
    changes = {k: float(v) for k, v in (kv.split("=") for kv in overrides)}
    jobs = [(track, changes, scale, 2 * i, (a, b)) for scale in scales for i in range(starts)]
    totals: dict[float, list[int]] = {}
    with ProcessPoolExecutor(2) as pool:
        for row in pool.map(race, jobs):
            print(json.dumps(row), flush=True)
            total = totals.setdefault(float(row["scale"]), [0, 0, 0, 0])  # type: ignore[arg-type]
            faults, illegal = row["faults"], row["illegal"]
            total[0] += bool(row["won"])
            total[1] += faults[0]  # type: ignore[index]
            total[2] += faults[1]  # type: ignore[index]
            total[3] += illegal[0]  # type: ignore[index]
    summary = {
        str(scale): f"won {t[0]}/{starts} mcts faults {t[1]} fixed faults {t[2]} illegal {t[3]}"
        for scale, t in totals.items()
    }
    print("SUMMARY", json.dumps(changes), json.dumps(summary))


if __name__ == "__main__":
    main()
