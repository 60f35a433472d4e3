"""One race of mcts-lqng (rollout check, depth 3, its settings overridden) against an opponent; one JSON line with
the result, the check's counts and the model's misses per plan (time, kart, miss [m]). From the repo root:

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session28/gate_race.py complex 0 mcts-rl '{"trust_miss": 1e9}'

Seed even: mcts-lqng starts in lane 2, odd: lane 3.
"""

import json
import sys
from dataclasses import replace

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

track, seed, opponent = sys.argv[1], int(sys.argv[2]), sys.argv[3]
overrides = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
lanes = (2, 3) if seed % 2 == 0 else (3, 2)
driver = make_controller("mcts-lqng", rollout_check_depth=3)
check = driver.planner.check  # type: ignore[attr-defined]
check.settings = replace(check.settings, **overrides)
spec = RaceSpec(track, ("mcts-lqng", opponent), seed=seed, start_lanes=lanes)
outcome = run_race(spec, drivers=[driver, make_controller(opponent)])
karts, counts = outcome.result.karts, check.counts
row = {
    "track": track,
    "seed": seed,
    "opponent": opponent,
    "settings": overrides,
    "winner": outcome.result.winner,
    "time": [round(k.finish_time, 3) for k in karts],
    "faults": [k.collisions_at_fault for k in karts],
    "illegal": [k.illegal_lane_changes for k in karts],
    "passes": [k.passes for k in karts],
    "checked": counts.checked,
    "changed": counts.changed,
    "untrusted": counts.untrusted,
    "rollouts": counts.rollouts,
    "changed_at": counts.changed_at,
    "misses": [(round(t, 2), k, round(m, 3)) for t, k, m in counts.misses],
    "wall": round(outcome.wall_seconds, 1),
}
print(json.dumps(row), flush=True)
