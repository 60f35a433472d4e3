"""Each fit of the other kart's models in one race, with the lanes the plan predicted for it (needs
``rival_fit_experiment.patch`` applied). From the repo root:

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session27/fit_debug.py > results/issue11/session27/fit_debug.txt
"""

import numpy as np

import controllers.rollout_check as rc
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

original_fit = rc.RolloutCheck.fit  # type: ignore[attr-defined]


def traced_fit(self: rc.RolloutCheck, observation: object) -> None:
    previous = self._previous  # type: ignore[attr-defined]
    before = {k: v.copy() for k, v in self._misses.items()}  # type: ignore[attr-defined]
    original_fit(self, observation)
    if previous is None:
        return
    seen, plan, kart = previous
    rival = next(k for k in seen.others() if k.index == kart)
    misses = self._misses.get(kart, np.zeros(3)) - before.get(kart, 0)  # type: ignore[attr-defined]
    predicted = [(w.checkpoint, w.lane) for w in plan.waypoints.get(kart, ())[:3]]
    print(
        f"t={seen.time:5.1f} other kart past checkpoint {rival.checkpoints_passed} in lane {rival.lane_now}; "
        f"plan predicts it {predicted}; misses (fixed's, generic, mcts-lqng's) {np.round(misses, 2).tolist()}"
    )


rc.RolloutCheck.fit = traced_fit  # type: ignore[attr-defined]
driver = make_controller("mcts-lqng", rollout_check_depth=1)
spec = RaceSpec("complex", ("mcts-lqng", "fixed-lqng"), seed=1, start_lanes=(3, 2), time_limit=50.0)
run_race(spec, drivers=[driver, make_controller("fixed-lqng")])
