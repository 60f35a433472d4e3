"""The mirror match with the new default: mcts-lqng against mcts-lqng (both with the gated check) next to the same
races with both as the search alone (rollout_check_depth=0), seeds 0-3 on complex and oval. One JSON line per race.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session28/mirror.py > results/issue11/session28/mirror.jsonl
"""

import json

from controllers.race import RaceSpec, run_race
from controllers.registry import make_agent

for track in ("complex", "oval"):
    for seed in range(4):
        lanes = (2, 3) if seed % 2 == 0 else (3, 2)
        for agent in ("mcts-lqng", "mcts-lqng:rollout_check_depth=0"):
            drivers = [make_agent(agent), make_agent(agent)]
            outcome = run_race(
                RaceSpec(track, ("mcts-lqng", "mcts-lqng"), seed=seed, start_lanes=lanes), drivers=drivers
            )
            counts = [d.planner.check.counts for d in drivers if hasattr(d.planner, "check")]  # type: ignore[attr-defined]
            karts = outcome.result.karts
            row = {
                "track": track,
                "seed": seed,
                "agent": agent,
                "winner": outcome.result.winner,
                "time": [k.finish_time for k in karts],
                "faults": [k.collisions_at_fault for k in karts],
                "illegal": [k.illegal_lane_changes for k in karts],
                "checked": [c.checked for c in counts],
                "untrusted": [c.untrusted for c in counts],
                "changed": [c.changed for c in counts],
                "wall_s": round(outcome.wall_seconds, 1),
            }
            print(json.dumps(row), flush=True)
