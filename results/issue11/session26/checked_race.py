"""One race of mcts-lqng with its rollout check (``rollout_check_depth``, controllers/rollout_check.py) against
fixed-lqng as registered.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session26/checked_race.py --depth 3 --lanes 2,3 \
        [--rival fixed|generic] [--track complex] [--seed 0]

``--rival generic``: the check models the kart ahead with the LQ tracker's generic settings (``LQNGParams()``)
instead of fixed-lqng's. Prints the race's figures as one JSON line."""

from __future__ import annotations

import argparse
import json
import time

from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGParams
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from controllers.rollout_check import CheckedPlanner, RolloutCheck


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--lanes", default="2,3")
    ap.add_argument("--track", default="complex")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--rival", default="fixed", choices=("fixed", "generic"))
    args = ap.parse_args()
    driver = make_controller("mcts-lqng", rollout_check_depth=args.depth)
    assert isinstance(driver, HierarchicalController) and isinstance(driver.planner, CheckedPlanner)
    check = driver.planner.check
    if args.rival == "generic":
        check = RolloutCheck(check.settings, check.ego_tracking, LQNGParams())
        driver.planner.check = check
    lanes = tuple(int(x) for x in args.lanes.split(","))
    spec = RaceSpec(track=args.track, controllers=("mcts-lqng", "fixed-lqng"), seed=args.seed, start_lanes=lanes)
    t0 = time.perf_counter()
    result = run_race(spec, drivers=[driver, make_controller("fixed-lqng")]).result
    karts = result.karts
    row = {
        "track": args.track,
        "lanes": lanes,
        "depth": args.depth,
        "rival": args.rival,
        "seed": args.seed,
        "winner": result.winner,
        "time": [k.finish_time for k in karts],
        "faults": [k.collisions_at_fault for k in karts],
        "contacts": [k.contacts for k in karts],
        "illegal": [k.illegal_lane_changes for k in karts],
        "passes": [k.passes for k in karts],
        "counts": vars(check.counts),
        "wall_s": round(time.perf_counter() - t0, 1),
    }
    print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
