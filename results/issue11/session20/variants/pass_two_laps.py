"""The 2-lap races of ``tests/test_tactical_traffic.py``'s 7%-slower pass on more seeds: mcts-lqng from lane 2 of
`complex` against fixed-lqng at ``speed_scale`` 0.93, as shipped, with session 17's tracker and planner (no pass
commitment, passing lanes blended) and with session 19's tracker (no pass on prediction). Prints (seed, setting,
passes, finish minus fixed-lqng's [s], collisions at fault, illegal lane changes). argv: comma-separated seeds.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session20/variants/pass_two_laps.py 2,4,6,12,14,16,18,20,22,28,30
"""

import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from controllers.tactical.high_level import MCTSPlanner


def race(seed: int, setting: str) -> tuple[object, ...]:
    """One 2-lap race from lane 2 with ``setting`` (shipped, s17 or s19)."""
    driver = make_controller("mcts-lqng")
    assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
    assert isinstance(driver.planner, MCTSPlanner)
    params = driver.tracker.params
    if setting == "s17":
        driver.planner.hold_gain = None
        driver.tracker = LQNGTracker(replace(params, pass_distance=0.0, pass_on_prediction=False))
    if setting == "s19":
        driver.tracker = LQNGTracker(replace(params, pass_on_prediction=False))
    spec = RaceSpec(track="complex", controllers=("mcts-lqng", "fixed-lqng"), laps=2, seed=seed, start_lanes=(2, 3))
    me, slow = run_race(spec, drivers=[driver, make_controller("fixed-lqng", speed_scale=0.93)]).result.karts
    assert me.finish_time is not None and slow.finish_time is not None
    margin = round(me.finish_time - slow.finish_time, 2)
    return seed, setting, me.passes, margin, me.collisions_at_fault, me.illegal_lane_changes


if __name__ == "__main__":
    seeds = [int(x) for x in sys.argv[1].split(",")]
    jobs = [(s, setting) for s in seeds for setting in ("shipped", "s17", "s19")]
    with ProcessPoolExecutor(2) as pool:
        for row in pool.map(race, *zip(*jobs, strict=True)):
            print(row)
