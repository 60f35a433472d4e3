"""Trace of a race of mcts-lqng (kart 0) against fixed-lqng at ``speed_scale`` SCALE: every EVERY steps (default
12) between T0 and T1 s, the checkpoints passed, the gap along the centre line (m, + = kart 0 behind), whether kart 0
is on a straight, speeds and lateral offsets. SPREAD: the race's start spread [s]. With the switches of
``tracker_switches.patch`` applied, those environment variables select the variants. argv: track seed scale [t0 t1].

    SPREAD=0.25 EVERY=10 PYTHONPATH=$PWD .venv/bin/python results/issue11/session20/variants/trace.py \\
        complex-reversed 6 1.0 0 14
"""

import os
import sys

from controllers.race import RaceSpec, load_any_track, run_race
from controllers.registry import make_controller
from sim_core.observation import observe
from sim_core.params import DT

track, seed, scale = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
t0 = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
t1 = float(sys.argv[5]) if len(sys.argv) > 5 else 1e9
every = int(os.environ.get("EVERY", "12"))
circuit = load_any_track(track)
lanes = (2, 3) if seed % 2 == 0 else (3, 2)
rows = []


def hook(world, drivers, step):
    t = (step + 1) * DT
    if step % every or not t0 <= t <= t1:
        return
    a, b = observe(world, 0)[0].karts[:2]
    rows.append(
        f"t={t:6.2f} cp={a.checkpoints_passed:3d}/{b.checkpoints_passed:3d} "
        f"gap={circuit.gap(a.progress, b.progress):+6.2f} str={int(circuit.section_is_straight(a.checkpoints_passed))} "
        f"v={a.speed:5.2f}/{b.speed:5.2f} lat={a.lateral:+5.2f}/{b.lateral:+5.2f}"
    )


spread = float(os.environ.get("SPREAD", "0"))
spec = RaceSpec(track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=seed, start_lanes=lanes, start_spread=spread)
drivers = [make_controller("mcts-lqng"), make_controller("fixed-lqng", speed_scale=scale)]
out = run_race(spec, drivers=drivers, on_step=hook)
print("\n".join(rows))
print([(round(k.finish_time or 0, 2), k.collisions_at_fault, k.passes) for k in out.result.karts])
