"""mcts-lqng as registered from lane 2 of complex against fixed-lqng: each kart's lane at its crossings of checkpoints 0-14 and
mcts-lqng's applied plans of the first 12 s (ego lanes, and the lanes it predicts for the other kart).

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session26/trace_mcts.py [seed]
"""
import sys, json
sys.path.insert(0, "results/issue11/session26")
from controllers.race import RaceSpec, run_race
from sim_core import state as st
crossings = {0: {}, 1: {}}
plans = []
def hook(world, drivers, step):
    for k in (0, 1):
        cp = int(world.istate[0, k, st.I_CP_PASSED])
        if cp not in crossings[k] and cp <= 14:
            crossings[k][cp] = (int(world.istate[0, k, st.I_LANE]) if hasattr(st, "I_LANE") else None, round(float(world.time[0]), 2))
    d = drivers[0]
    if d.active_plan is not None and (not plans or plans[-1][0] != d.plans_applied) and world.time[0] < 12:
        p = d.active_plan
        plans.append((d.plans_applied, round(float(world.time[0]), 2), [(w.checkpoint, w.lane) for w in p.ego_waypoints][:9],
                      {k: [(w.checkpoint, w.lane) for w in v][:6] for k, v in p.opponent_waypoints().items()}))
out = run_race(RaceSpec(track="complex", controllers=("mcts-lqng", "fixed-lqng"), seed=int(sys.argv[1]) if len(sys.argv) > 1 else 0, start_lanes=(2, 3)), on_step=hook)
print([k.finish_time for k in out.result.karts])
print("ego crossings", crossings[0]); print("opp crossings", crossings[1])
for p in plans: print(p)
