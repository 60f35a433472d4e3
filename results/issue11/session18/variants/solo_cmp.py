"""Where following costs: kart 0's crossing times in the 2-kart race against kart 0 alone from the same lane. Per
checkpoint: its loss to itself alone (and the step of it), its gap behind kart 1, the lateral offsets (race, alone,
kart 1) and its speeds (race, alone).

    PYTHONPATH=$PWD:results/issue11/session17/variants:results/issue11/session18/variants [switches] \\
        .venv/bin/python results/issue11/session18/variants/solo_cmp.py complex 0
"""

import sys

import s17patch  # noqa: F401
import s18patch  # noqa: F401

from controllers.race import RaceSpec, run_race
from sim_core.observation import observe
from sim_core.params import DT

track, seed = sys.argv[1], int(sys.argv[2])
karts = ("mcts-lqng", "fixed-lqng")
lanes = (2, 3) if seed % 2 == 0 else (3, 2)


def crossings(controllers, start_lanes):
    seen: dict[tuple[int, int], tuple[float, float, float]] = {}

    def hook(world, drivers, step):
        o = observe(world, 0)[0]
        for k in range(len(controllers)):
            seen.setdefault((k, o.karts[k].checkpoints_passed), ((step + 1) * DT, o.karts[k].speed, o.karts[k].lateral))

    out = run_race(RaceSpec(track=track, controllers=controllers, seed=seed, start_lanes=start_lanes), on_step=hook)
    return seen, out


race, out = crossings(karts, lanes)
solo, alone = crossings(karts[:1], lanes[:1])
print(
    "race",
    [round(k.finish_time or 0, 2) for k in out.result.karts],
    "alone",
    round(alone.result.karts[0].finish_time, 2),
)
previous = 0.0
for c in range(1, 3000):
    if (0, c) not in race or (0, c) not in solo or (1, c) not in race:
        continue
    loss = race[(0, c)][0] - solo[(0, c)][0]
    gap = race[(0, c)][0] - race[(1, c)][0]
    lat = f"{race[(0, c)][2]:+5.2f}/{solo[(0, c)][2]:+5.2f}/{race[(1, c)][2]:+5.2f}"
    speeds = f"{race[(0, c)][1]:5.2f}/{solo[(0, c)][1]:5.2f}"
    print(f"cp{c:3d} loss={loss:+5.2f} d={loss - previous:+5.2f} gap={gap:+5.2f} lat={lat} v={speeds}")
    previous = loss
