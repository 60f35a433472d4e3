"""Per-checkpoint crossings of a 2-kart race: kart 0's time behind kart 1 (s), speeds and lateral offsets, then
each kart's (finish time, collisions at fault, passes). Optional ``scale``: fixed-lqng's ``speed_scale``.

    PYTHONPATH=$PWD:results/issue11/session17/variants:results/issue11/session18/variants [switches] \\
        .venv/bin/python results/issue11/session18/variants/cross.py complex 0 [0.95]
"""

import sys

import s17patch  # noqa: F401
import s18patch  # noqa: F401

from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from sim_core.observation import observe
from sim_core.params import DT

track, seed = sys.argv[1], int(sys.argv[2])
scale = float(sys.argv[3]) if len(sys.argv) > 3 else 1.0
lanes = (2, 3) if seed % 2 == 0 else (3, 2)
crossings: list[dict[int, tuple[float, float, float]]] = [{}, {}]


def hook(world, drivers, step):
    o = observe(world, 0)[0]
    for k in range(2):
        c = o.karts[k].checkpoints_passed
        crossings[k].setdefault(c, ((step + 1) * DT, o.karts[k].speed, o.karts[k].lateral))


spec = RaceSpec(track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=seed, start_lanes=lanes)
drivers = [make_controller("mcts-lqng"), make_controller("fixed-lqng", speed_scale=scale)]
out = run_race(spec, drivers=drivers, on_step=hook)
for c in sorted(crossings[0]):
    if c in crossings[1]:
        a, b = crossings[0][c], crossings[1][c]
        print(f"cp{c:3d} dt={a[0] - b[0]:+6.2f} v={a[1]:5.2f}/{b[1]:5.2f} lat={a[2]:+5.2f}/{b[2]:+5.2f}")
print([(round(k.finish_time or 0, 2), k.collisions_at_fault, k.passes) for k in out.result.karts])
