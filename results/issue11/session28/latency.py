"""Is the check's lane-2 win on complex robust to a plan's delay? Headless races (no budget: whole plans) of
mcts-lqng (default) against fixed-lqng from lane 2 (seed 0), plans applied LATENCY seconds after they are asked for
(``RaceSpec.plan_latency``; the series use 0.1 s). One JSON line per latency.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session28/latency.py 0.1 0.3 0.5 1.0
"""

import json
import sys

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

for latency in (float(x) for x in sys.argv[1:]):
    drivers = [make_controller("mcts-lqng"), make_controller("fixed-lqng")]
    spec = RaceSpec("complex", ("mcts-lqng", "fixed-lqng"), seed=0, start_lanes=(2, 3), plan_latency=latency)
    outcome = run_race(spec, drivers=drivers)
    counts = drivers[0].planner.check.counts  # type: ignore[attr-defined]
    row = {
        "plan_latency": latency,
        "winner": outcome.result.winner,
        "time": [k.finish_time for k in outcome.result.karts],
        "faults": [k.collisions_at_fault for k in outcome.result.karts],
        "checked": counts.checked,
        "untrusted": counts.untrusted,
        "changed_at": counts.changed_at,
        "first_misses": [round(m, 3) for _, _, m in counts.misses[:10]],
    }
    print(json.dumps(row), flush=True)
