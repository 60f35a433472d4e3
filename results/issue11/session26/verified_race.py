"""One race of the simulation-checked mcts-lqng prototype (verified.py) against fixed-lqng as registered.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session26/verified_race.py --depth 3 --lanes 2,3 \
        [--opponent-model fixed|generic] [--track complex]

Prints the race's figures as JSON, then the first plans' checks (time, first checkpoint of the window, the
search's lanes, the best candidate and its score)."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from verified import verified_mcts_lqng  # noqa: E402

from controllers.lq.tracker import FIXED_LINE_TRACKING, LQNGParams  # noqa: E402
from controllers.race import RaceSpec, run_race  # noqa: E402
from controllers.registry import make_controller  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--lanes", default="2,3")
    ap.add_argument("--track", default="complex")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--opponent-model", default="fixed", choices=("fixed", "generic"))
    args = ap.parse_args()
    model = FIXED_LINE_TRACKING if args.opponent_model == "fixed" else LQNGParams()
    driver = verified_mcts_lqng(model, exhaustive=True, depth=args.depth)
    driver.planner.trace = []  # type: ignore[attr-defined]
    lanes = tuple(int(x) for x in args.lanes.split(","))
    t0 = time.time()
    spec = RaceSpec(track=args.track, controllers=("verified", "fixed-lqng"), seed=args.seed, start_lanes=lanes)
    result = run_race(spec, drivers=[driver, make_controller("fixed-lqng")]).result
    karts = result.karts
    print(json.dumps({
        "track": args.track, "depth": args.depth, "lanes": lanes, "opponent_model": args.opponent_model,
        "time": [k.finish_time for k in karts], "faults": [k.collisions_at_fault for k in karts],
        "contacts": [k.contacts for k in karts], "illegal": [k.illegal_lane_changes for k in karts],
        "passes": [k.passes for k in karts], "stats": vars(driver.planner.stats),  # type: ignore[attr-defined]
        "wall_s": round(time.time() - t0, 1),
    }), flush=True)
    for t, first, searched, scores in driver.planner.trace[:25]:  # type: ignore[attr-defined]
        print(t, first, searched, max(scores.items(), key=lambda kv: kv[1]))


if __name__ == "__main__":
    main()
