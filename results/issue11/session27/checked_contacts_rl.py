"""Where mcts-lqng with the rollout check (depth 3) ran into mcts-rl on ``complex`` from lane 3 (seed 1 of
``checked_vs_grid.sh``): at each collision at fault or contact, both karts' (checkpoints passed, lane, lateral
offset [m], speed [m/s], progress [m]); and each plan the check changed before it (time, the search's lanes, the
lanes sent, the other kart's lanes the plan predicted).

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session27/checked_contacts_rl.py [OPPONENT] \\
        > results/issue11/session27/checked_contacts_rl.txt
"""

import json
import sys

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from controllers.rollout_check import CheckedPlanner
from sim_core import state as st
from sim_core.observation import kart_views

opponent = sys.argv[1] if len(sys.argv) > 1 else "mcts-rl"
seen = [0, 0, 0, 0]
driver = make_controller("mcts-lqng", rollout_check_depth=3)
planner = driver.planner  # type: ignore[attr-defined]
assert isinstance(planner, CheckedPlanner)
original_check = planner.check.check


def logged_check(observation, plan, line_lanes, lane_limit):  # type: ignore[no-untyped-def]
    checked = original_check(observation, plan, line_lanes, lane_limit)
    if checked is not plan:
        other = next(iter(observation.others()))
        print(
            json.dumps(
                {
                    "t": round(observation.time, 2),
                    "changed": [(w.checkpoint, w.lane) for w in plan.ego_waypoints[:4]],
                    "sent": [(w.checkpoint, w.lane) for w in checked.ego_waypoints[:4]],
                    "other_predicted": [(w.checkpoint, w.lane) for w in plan.waypoints.get(other.index, ())[:3]],
                }
            ),
            flush=True,
        )
    return checked


planner.check.check = logged_check  # type: ignore[method-assign]


def hook(world, drivers, step):  # type: ignore[no-untyped-def]
    i = world.istate[0]
    now = [int(i[0, st.I_FAULTS]), int(i[1, st.I_FAULTS]), int(i[0, st.I_CONTACTS]), int(i[1, st.I_CONTACTS])]
    if now != seen:
        views = kart_views(world, 0)
        karts = [
            (k.checkpoints_passed, k.lane_now, round(k.lateral, 2), round(k.speed, 2), round(k.progress, 1))
            for k in views
        ]
        print(json.dumps({"t": round(float(world.time[0]), 2), "faults": now[:2], "contacts": now[2:], "karts": karts}))
        seen[:] = now


spec = RaceSpec("complex", ("mcts-lqng", opponent), seed=1, start_lanes=(3, 2))
outcome = run_race(spec, drivers=[driver, make_controller(opponent)], on_step=hook)
print(json.dumps({"finish": [k.finish_time for k in outcome.result.karts], "winner": outcome.result.winner}))
