"""The same races of mcts-lqng against OPP with and without ``pass_on_prediction`` (seeds 0..N-1, start lanes
alternating): (setting, seed, finish times, collisions at fault, passes). argv: track opponent N.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session20/variants/same_races.py complex fixed-rl 4
"""

import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller


def race(track: str, opponent: str, seed: int, on: bool) -> tuple[object, ...]:
    """One race, mcts-lqng with (``on``) or without the pass on prediction."""
    driver = make_controller("mcts-lqng")
    assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
    if not on:
        driver.tracker = LQNGTracker(replace(driver.tracker.params, pass_on_prediction=False))
    lanes = (2, 3) if seed % 2 == 0 else (3, 2)
    spec = RaceSpec(track=track, controllers=("mcts-lqng", opponent), seed=seed, start_lanes=lanes)
    karts = run_race(spec, drivers=[driver, make_controller(opponent)]).result.karts
    times = [round(k.finish_time or 999.0, 2) for k in karts]
    return on, seed, times, [k.collisions_at_fault for k in karts], [k.passes for k in karts]


if __name__ == "__main__":
    track, opponent, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
    jobs = [(track, opponent, s, on) for on in (True, False) for s in range(n)]
    with ProcessPoolExecutor(2) as pool:
        for row in pool.map(race, *zip(*jobs, strict=True)):
            print(row)
