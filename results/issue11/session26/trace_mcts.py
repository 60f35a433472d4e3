"""mcts-lqng as registered from lane 2 of complex against fixed-lqng: each kart's lane at its crossings of
checkpoints 0-14 and mcts-lqng's applied plans of the first 12 s (ego lanes, and the lanes it predicts for the other
kart).

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session26/trace_mcts.py [seed]
"""

from __future__ import annotations

import sys

from controllers.race import RaceSpec, run_race
from sim_core import state as st

crossings: dict[int, dict[int, tuple[int, float]]] = {0: {}, 1: {}}
plans: list[tuple[object, ...]] = []


def hook(world, drivers, step):  # type: ignore[no-untyped-def]
    for k in (0, 1):
        cp = int(world.istate[0, k, st.I_CP_PASSED])
        if cp not in crossings[k] and cp <= 14:
            crossings[k][cp] = (int(world.istate[0, k, st.I_LANE]), round(float(world.time[0]), 2))
    d = drivers[0]
    if d.active_plan is not None and (not plans or plans[-1][0] != d.plans_applied) and world.time[0] < 12:
        p = d.active_plan
        ego = [(w.checkpoint, w.lane) for w in p.ego_waypoints][:9]
        others = {k: [(w.checkpoint, w.lane) for w in v][:6] for k, v in p.opponent_waypoints().items()}
        plans.append((d.plans_applied, round(float(world.time[0]), 2), ego, others))


def main() -> None:
    seed = int(sys.argv[1]) if len(sys.argv) > 1 else 0
    spec = RaceSpec(track="complex", controllers=("mcts-lqng", "fixed-lqng"), seed=seed, start_lanes=(2, 3))
    out = run_race(spec, on_step=hook)
    print([k.finish_time for k in out.result.karts])
    print("ego crossings", crossings[0])
    print("opp crossings", crossings[1])
    for p in plans:
        print(p)


if __name__ == "__main__":
    main()
