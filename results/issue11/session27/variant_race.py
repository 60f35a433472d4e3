"""One race of mcts-lqng (rollout check of depth 3, its settings overridden) against an opponent; one JSON line.

Any field of ``RolloutCheckSettings`` can be overridden. ``complete_rival`` and ``fit_rival``, which session 27 tried,
need the check of ``rival_fit_experiment.patch`` (``git apply`` it first). For example, from the repo root:

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session27/variant_race.py complex 0 fixed-lqng \
        '{"complete_rival": true, "fit_rival": false}'
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
    "rollouts": counts.rollouts,
    "fits": getattr(counts, "fits", None),
    "other_model": getattr(counts, "other_model", None),
    "wall": round(outcome.wall_seconds, 1),
}
print(json.dumps(row), flush=True)
