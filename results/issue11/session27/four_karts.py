"""A 4-kart race on ``complex`` (default grid: lanes 2, 3, 1, 4): two mcts-lqng with the rollout check (depth 3) and
two fixed-lqng; the same with mcts-lqng as registered for comparison (``--plain``). One JSON line.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session27/four_karts.py [--plain]
"""

import json
import sys

from controllers.race import RaceSpec, run_race

mcts = "mcts-lqng" if "--plain" in sys.argv else "mcts-lqng:rollout_check_depth=3"
spec = RaceSpec("complex", (mcts, "fixed-lqng", mcts, "fixed-lqng"), seed=0)
outcome = run_race(spec)
karts = [
    (round(k.finish_time, 2), k.collisions_at_fault, k.illegal_lane_changes, k.passes) for k in outcome.result.karts
]
print(
    json.dumps(
        {
            "karts": spec.controllers,
            "winner": outcome.result.winner,
            "finish_faults_illegal_passes": karts,
            "wall_s": round(outcome.wall_seconds, 1),
        }
    )
)
