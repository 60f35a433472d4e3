"""Where the contacts and passes happened in the checked series' complex race of seed 1 (mcts-lqng with
rollout_check_depth=3 from lane 3 against fixed-lqng): time, collisions at fault per kart, passes so far, and each
kart's (checkpoints passed, lane, lateral offset, speed, progress).

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session26/checked_contacts.py
"""

import json

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from sim_core import state as st
from sim_core.observation import kart_views

seen = [0, 0, 0]


def hook(world, drivers, step):
    i = world.istate[0]
    now = [int(i[0, st.I_FAULTS]), int(i[1, st.I_FAULTS]), int(i[0, st.I_PASSES] + i[1, st.I_PASSES])]
    if now != seen:
        v = kart_views(world, 0)
        print(
            json.dumps(
                {
                    "t": round(float(world.time[0]), 2),
                    "faults": now[:2],
                    "passes": now[2],
                    "karts": [
                        (k.checkpoints_passed, k.lane_now, round(k.lateral, 2), round(k.speed, 2), round(k.progress, 1))
                        for k in v
                    ],
                    "straight": bool(world.track.section_is_straight(v[0].checkpoints_passed)),
                }
            )
        )
        seen[:] = now


spec = RaceSpec(track="complex", controllers=("mcts-lqng", "fixed-lqng"), seed=1, start_lanes=(3, 2))
out = run_race(
    spec, drivers=[make_controller("mcts-lqng", rollout_check_depth=3), make_controller("fixed-lqng")], on_step=hook
)
print([k.finish_time for k in out.result.karts])
