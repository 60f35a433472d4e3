"""A headless race of mcts-lqng (default) against fixed-lqng on complex with plans applied LATENCY s after they are
asked for, the check modelling a delay of LEAD s (``RolloutCheckSettings.lead_s``). One JSON line.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session28/lead_race.py LATENCY LEAD [SEED]
"""

import json
import sys
from dataclasses import replace

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

latency = float(sys.argv[1])
lead = float(sys.argv[2])
seed = int(sys.argv[3]) if len(sys.argv) > 3 else 0
d = make_controller("mcts-lqng")
c = d.planner.check
c.settings = replace(c.settings, lead_s=lead)
c.lead_s = lead
lanes = (2, 3) if seed % 2 == 0 else (3, 2)
spec = RaceSpec("complex", ("mcts-lqng", "fixed-lqng"), seed=seed, start_lanes=lanes, plan_latency=latency)
o = run_race(spec, drivers=[d, make_controller("fixed-lqng")])
print(
    json.dumps(
        {
            "plan_latency": latency,
            "lead_s": lead,
            "seed": seed,
            "winner": o.result.winner,
            "time": [k.finish_time for k in o.result.karts],
            "faults": [k.collisions_at_fault for k in o.result.karts],
            "changed_at": c.counts.changed_at[:12],
        }
    ),
    flush=True,
)
