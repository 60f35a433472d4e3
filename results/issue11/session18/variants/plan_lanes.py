"""Every plan mcts-lqng (kart 0) applies while it is between two checkpoints: its waypoints (``*``: off the racing
line's lane; lane / planned speed @ predicted time) and the other kart's predicted ones. argv: track seed first last
[speed_scale of fixed-lqng].

    PYTHONPATH=$PWD:results/issue11/session17/variants:results/issue11/session18/variants \\
        .venv/bin/python results/issue11/session18/variants/plan_lanes.py complex 0 33 44 0.92
"""

import sys

import s17patch  # noqa: F401
import s18patch  # noqa: F401

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from sim_core.observation import observe
from sim_core.params import DT

track, seed, first, last = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
scale = float(sys.argv[5]) if len(sys.argv) > 5 else 1.0
lanes = (2, 3) if seed % 2 == 0 else (3, 2)
applied = [0]


def hook(world, drivers, step):
    driver = drivers[0]
    if driver.plans_applied == applied[0]:
        return
    applied[0] = driver.plans_applied
    o = observe(world, 0)[0]
    me, other = o.karts[0], o.karts[1]
    plan = driver.active_plan
    if plan is None or not first <= me.checkpoints_passed <= last:
        return
    line = driver.planner._line_lanes
    print(
        f"t={(step + 1) * DT:.2f} cp{me.checkpoints_passed} lane {me.lane} lat {me.lateral:+.2f}"
        f" v {me.speed:.2f} | other cp{other.checkpoints_passed} lat {other.lateral:+.2f} v {other.speed:.2f}"
    )
    marks = ["" if w.lane == line[w.checkpoint % len(line)] else "*" for w in plan.ego_waypoints]
    print(
        "   ego",
        " ".join(
            f"{w.checkpoint}:L{w.lane}{m}/{w.speed:.1f}@{w.time:.2f}"
            for w, m in zip(plan.ego_waypoints, marks, strict=True)
        ),
    )
    for kart, waypoints in plan.opponent_waypoints().items():
        print(f"   {kart}  ", " ".join(f"{w.checkpoint}:L{w.lane}@{w.time:.2f}" for w in waypoints))


spec = RaceSpec(track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=seed, start_lanes=lanes)
run_race(spec, drivers=[make_controller("mcts-lqng"), make_controller("fixed-lqng", speed_scale=scale)], on_step=hook)
