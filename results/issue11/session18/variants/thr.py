"""Lane-2 starts only: mcts-lqng against fixed-lqng at each ``speed_scale``, one race per seed, with the switches of
session 17's ``s17patch.py`` and this session's ``s18patch.py`` from the environment.

    PYTHONPATH=$PWD:results/issue11/session17/variants:results/issue11/session18/variants HMARGIN=0.15 \\
        .venv/bin/python results/issue11/session18/variants/thr.py complex 0.95,0.93 0,2,4,6
"""

import sys
from concurrent.futures import ProcessPoolExecutor

import s17patch  # noqa: F401
import s18patch  # noqa: F401

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

track = sys.argv[1]
scales = [float(x) for x in sys.argv[2].split(",")]
seeds = [int(x) for x in sys.argv[3].split(",")]


def one(job):
    scale, seed = job
    spec = RaceSpec(track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=seed, start_lanes=(2, 3))
    drivers = [make_controller("mcts-lqng"), make_controller("fixed-lqng", speed_scale=scale)]
    a, b = run_race(spec, drivers=drivers).result.karts
    faults = a.collisions_at_fault + b.collisions_at_fault
    margin = round(a.finish_time - b.finish_time, 2)
    return scale, a.finish_time < b.finish_time, a.passes, faults, a.illegal_lane_changes, margin


if __name__ == "__main__":
    with ProcessPoolExecutor(2) as pool:
        rows = list(pool.map(one, [(f, s) for f in scales for s in seeds]))
    for f in scales:
        mine = [r for r in rows if r[0] == f]
        wins, passes = sum(r[1] for r in mine), sum(r[2] for r in mine)
        faults, illegal = sum(r[3] for r in mine), sum(r[4] for r in mine)
        margins = [r[5] for r in mine]
        print(f"scale {f}: wins {wins}/{len(mine)} passes {passes} faults {faults} illegal {illegal} dt {margins}")
