"""Lane-2 starts only: mcts-lqng vs fixed-lqng(speed_scale), seeds 0,2,4,6 per scale, with s17patch's switches.

    PYTHONPATH=$PWD:results/issue11/session17/variants TRK=follow_band=1.6 .venv/bin/python \\
        results/issue11/session17/variants/thr.py complex 0.95,0.92,0.9,0.88,0.85 0,2,4,6
"""

import sys
from concurrent.futures import ProcessPoolExecutor

import s17patch  # noqa

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

track = sys.argv[1] if len(sys.argv) > 1 else "complex"
scales = [float(x) for x in (sys.argv[2] if len(sys.argv) > 2 else "0.97,0.95,0.92,0.9").split(",")]
seeds = [int(x) for x in (sys.argv[3] if len(sys.argv) > 3 else "0,2,4,6").split(",")]


def one(args):
    f, s = args
    spec = RaceSpec(track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=s, start_lanes=(2, 3))
    a, b = run_race(
        spec, drivers=[make_controller("mcts-lqng"), make_controller("fixed-lqng", speed_scale=f)]
    ).result.karts
    return f, s, a.finish_time < b.finish_time, a.passes, a.collisions_at_fault, round(a.finish_time - b.finish_time, 2)


jobs = [(f, s) for f in scales for s in seeds]
with ProcessPoolExecutor(2) as pool:
    rows = list(pool.map(one, jobs))
for f in scales:
    r = [x for x in rows if x[0] == f]
    wins, passes, faults = sum(x[2] for x in r), sum(x[3] for x in r), sum(x[4] for x in r)
    print(f"F={f} wins {wins}/{len(r)} passes {passes} faults {faults} margins {[x[5] for x in r]}")
