"""Session 19's first device run (``../device_pass_threshold.jsonl``, 524 races on the lent H200's 16 cores):

* the pass threshold on ``complex`` (mcts-lqng from lane 2 against fixed-lqng at ``speed_scale`` 0.90-0.97, 16 seeds
  each), "old" = a80f90a's ``MCTSPlanner._prefer_racing_line``, "new" = the same with ``skipped_waypoints.patch``;
* first spread-start series, with a scratch launch delay that held the kart on the brake (throttle -1, which
  backs a standing kart up at up to 0.24 m/s; ``RaceSpec.start_spread`` now holds throttle 0).

Run from the repo root with the patch applied to the tree and a80f90a's file beside it:

    mkdir -p .dev && git show a80f90a:controllers/tactical/high_level.py > .dev/high_level_head.py
    PYTHONPATH=$PWD python results/issue11/session19/variants/device_jobs.py all 16 out.jsonl
"""

import importlib.util
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from controllers.base import Action
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from controllers.tactical import high_level

_spec = importlib.util.spec_from_file_location("high_level_head", ".dev/high_level_head.py")
_head = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_head)
NEW = high_level.MCTSPlanner._prefer_racing_line
OLD = _head.MCTSPlanner._prefer_racing_line


def delayed(driver, delay):
    orig = driver.act

    def act(obs):
        if obs.time < delay:
            return Action(0.0, -1.0)
        return orig(obs)

    driver.act = act
    return driver


def one(job):
    variant, track, names, scale, seed, reaction = job
    high_level.MCTSPlanner._prefer_racing_line = NEW if variant == "new" else OLD
    lanes = (2, 3) if seed % 2 == 0 else (3, 2)
    spec = RaceSpec(track=track, controllers=names, seed=seed, start_lanes=lanes)
    drivers = [
        make_controller(names[0]),
        make_controller(names[1], speed_scale=scale) if scale != 1.0 else make_controller(names[1]),
    ]
    delays = [0.0, 0.0]
    if reaction > 0:
        rng = np.random.default_rng(10_007 * seed + 17)
        delays = [float(x) for x in rng.uniform(0.0, reaction, 2)]
        drivers = [delayed(d, t) for d, t in zip(drivers, delays)]
    t0 = time.perf_counter()
    out = run_race(spec, drivers=drivers)
    a, b = out.result.karts
    return dict(
        variant=variant,
        track=track,
        names=names,
        scale=scale,
        seed=seed,
        reaction=reaction,
        delays=delays,
        lanes=lanes,
        finish=[a.finish_time, b.finish_time],
        win=bool(a.finish_time < b.finish_time),
        passes=[a.passes, b.passes],
        faults=[a.collisions_at_fault, b.collisions_at_fault],
        illegal=[a.illegal_lane_changes, b.illegal_lane_changes],
        wall=time.perf_counter() - t0,
    )


def jobs(which):
    js = []
    if which in ("thr", "all"):
        for v in ("old", "new"):
            for s in (0.90, 0.92, 0.93, 0.94, 0.95, 0.96, 0.97):
                for seed in range(0, 32, 2):
                    js.append((v, "complex", ("mcts-lqng", "fixed-lqng"), s, seed, 0.0))
    if which in ("spread", "all"):
        for v in ("old", "new"):
            for seed in range(50):
                js.append((v, "complex", ("mcts-lqng", "fixed-lqng"), 1.0, seed, 0.1))
        for seed in range(50):
            js.append(("old", "complex", ("fixed-lqng", "fixed-lqng"), 1.0, seed, 0.1))
        for seed in range(50):
            js.append(("new", "complex", ("mcts-lqng", "fixed-lqng"), 1.0, seed, 0.25))
        for track in ("complex-reversed", "oval-reversed"):
            for seed in range(50):
                js.append(("new", track, ("mcts-lqng", "fixed-lqng"), 1.0, seed, 0.1))
    return js


if __name__ == "__main__":
    which, workers, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    js = jobs(which)
    if len(sys.argv) > 4:
        js = js[: int(sys.argv[4])]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(workers) as pool, open(path, "w") as f:
        for r in pool.map(one, js, chunksize=1):
            f.write(json.dumps(r) + "\n")
            f.flush()
    print(f"{len(js)} races in {time.perf_counter() - t0:.0f} s", flush=True)
