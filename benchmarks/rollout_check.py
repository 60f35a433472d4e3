"""Plan time of the rollout check (controllers/rollout_check.py) behind mcts-lqng's search, next to the search's
own plan, in the situation it is for: the first corner of ``complex``, 6 s after a start from lane 2 beside
fixed-lqng in lane 3 (the other kart just ahead).

Both karts race as registered (``controllers.race.run_race``) for 6 s; then, from that one observation, mcts-lqng's
search plans alone and with the check of depth 1, 2 and 3 (every legal lane sequence: 4, 16 and 64 rollouts),
``ROUNDS`` times each, alternating. Reported: the median seconds per plan, the rollouts per check and the
milliseconds per rollout; and, for the depth-3 check's candidates, the seconds to score them as a tree (shared
beginnings raced once, the check's way) next to racing each alone, with the steps each took. Timings depend on
the machine and on what else runs. Run from the repo root:
``.venv/bin/python benchmarks/rollout_check.py`` (``--help``: rounds and depths). The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from functools import partial

from controllers.base import RaceContext
from controllers.checked_planner import CheckedPlanner, with_rollout_check
from controllers.hierarchical import HierarchicalController
from controllers.lq.presets import fixed_line_tracker
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from controllers.rollout_check import RolloutCheckSettings
from sim_core.observation import Observation, observe
from sim_core.world import World

SECONDS = 6.0  # the karts are in the first corner, fixed-lqng just ahead
DEPTHS = (1, 2, 3)
ROUNDS = 3


def first_corner() -> tuple[Observation, RaceContext]:
    """mcts-lqng's observation 6 s into a lane-2 start on complex against fixed-lqng, and its race context."""
    raced: list[World] = []
    spec = RaceSpec("complex", ("mcts-lqng", "fixed-lqng"), start_lanes=(2, 3), time_limit=SECONDS)
    run_race(spec, on_step=lambda world, drivers, step: raced.append(world) if not raced else None)
    world = raced[0]
    context = RaceContext(world.track, world.params.kart, 0, 2, world.lane_change_limit, seed=0)
    return observe(world, 0)[0], context


def tree_against_alone(planner: object, observation: Observation, rounds: int = ROUNDS) -> dict[str, float]:
    """Seconds (median of ``rounds``, alternating) and steps to score the check's candidates at ``observation``
    as a tree and one by one; the scores must agree."""
    assert isinstance(planner, CheckedPlanner)
    check, inner = planner.check, planner.inner
    plan = inner.plan(observation)
    rival = check.rival(observation)
    assert rival is not None, "the benchmark's situation has the other kart in reach"
    target = plan.ego_waypoints[check.settings.depth].checkpoint + check.settings.settle
    candidates = check.candidates(plan, observation.me, inner.line_lanes, inner.lane_limit)
    times: dict[str, list[float]] = {"tree": [], "alone": []}
    steps: dict[str, int] = {}
    for _ in range(rounds):
        before, t0 = check.counts.steps, time.perf_counter()
        tree = check.scores(observation, rival, plan, target, candidates)
        times["tree"].append(time.perf_counter() - t0)
        steps["tree"] = check.counts.steps - before
        before, t0 = check.counts.steps, time.perf_counter()
        alone = {c: check.score(observation, rival, check.with_lanes_plan(plan, c), target) for c in candidates}
        times["alone"].append(time.perf_counter() - t0)
        steps["alone"] = check.counts.steps - before
        assert tree == alone, "the tree's scores differ from racing each candidate alone"
    tree_s, alone_s = statistics.median(times["tree"]), statistics.median(times["alone"])
    print(f"{len(candidates)} candidates: tree {tree_s:.2f} s ({steps['tree']} steps), one by one {alone_s:.2f} s")
    return {
        "candidates": len(candidates),
        "tree_s": round(tree_s, 3),
        "alone_s": round(alone_s, 3),
        "tree_steps": steps["tree"],
        "alone_steps": steps["alone"],
        "tree_speedup": round(alone_s / tree_s, 2),
    }


def main() -> None:
    """Plan alone and with each depth's check, then score the deepest check's candidates both ways; print a line
    each, then the JSON summary."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=ROUNDS, help="plans timed per depth (median kept)")
    parser.add_argument(
        "--depths",
        type=lambda s: tuple(int(x) for x in s.split(",")),
        default=DEPTHS,
        help="check depths, comma separated",
    )
    args = parser.parse_args()
    depths: tuple[int, ...] = args.depths
    observation, context = first_corner()
    planners = {}
    for depth in (0, *depths):
        # the gate off: from one observation nothing is ever measured, and a gated check would race no rollout
        driver = make_controller("mcts-lqng")
        assert isinstance(driver, HierarchicalController)
        if depth > 0:  # the kart ahead modelled as fixed-lqng's tracker: the situation is a race against it
            settings = RolloutCheckSettings(depth=depth, trust_miss=0.0)
            with_rollout_check(driver, settings, partial(fixed_line_tracker, 4))
        driver.planner.reset(context)
        driver.planner.plan(observation)  # compiles, and fills the search's reused tree as a race would
        planners[depth] = driver.planner
    seconds: dict[int, list[float]] = {depth: [] for depth in planners}
    rollouts: dict[int, int] = {}
    for _ in range(args.rounds):
        for depth, planner in planners.items():
            before = planner.check.counts.rollouts if isinstance(planner, CheckedPlanner) else 0
            t0 = time.perf_counter()
            planner.plan(observation)
            seconds[depth].append(time.perf_counter() - t0)
            if isinstance(planner, CheckedPlanner):
                rollouts[depth] = planner.check.counts.rollouts - before
    median = {depth: statistics.median(times) for depth, times in seconds.items()}
    tree = tree_against_alone(planners[depths[-1]], observation, args.rounds)
    for depth, value in median.items():
        label = "search alone" if depth == 0 else f"check depth {depth} ({rollouts[depth]} rollouts)"
        print(f"{label}: {value * 1000:.1f} ms per plan")
    per_rollout = {
        depth: (median[depth] - median[0]) / rollouts[depth] * 1000 for depth in depths if rollouts.get(depth)
    }
    print(
        json.dumps(
            {
                "search_plan_ms": round(median[0] * 1000, 2),
                "checked_plan_ms": {str(d): round(median[d] * 1000, 1) for d in depths},
                "rollouts_per_check": {str(d): rollouts.get(d, 0) for d in depths},
                "ms_per_rollout": {str(d): round(v, 2) for d, v in per_rollout.items()},
                **tree,
            }
        )
    )


if __name__ == "__main__":
    main()
