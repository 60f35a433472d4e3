"""The speed-ups of session 27 change no number: hashes of every state array at the end of two races (complex,
mcts-lqng against fixed-lqng for 40 s; oval, four karts for 25 s) and of the 16 rollout scores of a depth-2 check
in complex's first corner. The same line before and after a change means the same races, to the last bit.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session27/bit_for_bit.py

Session 27's output, the same at the session's start (commit 1aa09aa, its RolloutCheck.score racing each candidate;
this script's equivalent then), after the tracker's speed-up (70d9f89), the tree (b362ef8) and the agents (f69a2a1):
{"race0": "2ac50bac3474d3dd", "race1": "f254c95a5ce78572", "scores": "9f85ced29f93f7bf", "n": 16}
"""

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from controllers.rollout_check import CheckedPlanner
from sim_core.world import World

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))
from rollout_check import first_corner


def digest(world: World) -> str:
    """A hash of every state array of ``world``."""
    hashed = hashlib.sha256()
    for _, values in sorted(world.state_arrays().items()):
        hashed.update(np.ascontiguousarray(values).tobytes())
    return hashed.hexdigest()[:16]


def raced_world(spec: RaceSpec) -> World:
    """The world of ``spec`` raced to its end."""
    raced: list[World] = []
    run_race(spec, on_step=lambda world, drivers, step: raced.append(world) if not raced else None)
    return raced[0]


def main() -> None:
    out: dict[str, object] = {}
    specs = [
        RaceSpec("complex", ("mcts-lqng", "fixed-lqng"), start_lanes=(2, 3), time_limit=40.0),
        RaceSpec("oval", ("fixed-lqng", "mcts-lqng", "fixed-lqng", "mcts-lqng"), time_limit=25.0, seed=3),
    ]
    for i, spec in enumerate(specs):
        out[f"race{i}"] = digest(raced_world(spec))
    observation, context = first_corner()
    driver = make_controller("mcts-lqng", rollout_check_depth=2)
    planner = driver.planner  # type: ignore[attr-defined]
    assert isinstance(planner, CheckedPlanner)
    planner.reset(context)
    plan = planner.inner.plan(observation)
    check = planner.check
    rival = check.rival(observation)
    assert rival is not None
    target = plan.ego_waypoints[check.settings.depth].checkpoint + check.settings.settle
    candidates = check.candidates(plan, observation.me, planner.inner.line_lanes, planner.inner.lane_limit)
    scores = [check.score(observation, rival, check.with_lanes_plan(plan, c), target) for c in candidates]
    out["scores"] = hashlib.sha256(np.array(scores).tobytes()).hexdigest()[:16]
    out["n"] = len(scores)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
