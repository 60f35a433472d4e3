"""The moments a kart's collisions at fault rise in a race of mcts-lqng (kart 0) against OPP (default fixed-lqng),
with the 0.8 s before (gap along the centre line, speeds, lateral offsets, headings). argv: track seed spread.

    OPP=fixed-rl PYTHONPATH=$PWD .venv/bin/python results/issue11/session20/variants/faults.py complex 1 0
"""

import os
import sys

import sim_core.state as st
from controllers.race import RaceSpec, load_any_track, run_race
from controllers.registry import make_controller
from sim_core.observation import observe
from sim_core.params import DT

track, seed, spread = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
opponent = os.environ.get("OPP", "fixed-lqng")
circuit = load_any_track(track)
lanes = (2, 3) if seed % 2 == 0 else (3, 2)
last = [0, 0]
history: list[str] = []


def hook(world, drivers, step):
    a, b = observe(world, 0)[0].karts[:2]
    history.append(
        f"t={(step + 1) * DT:6.2f} cp={a.checkpoints_passed}/{b.checkpoints_passed} "
        f"gap={circuit.gap(a.progress, b.progress):+5.2f} v={a.speed:5.2f}/{b.speed:5.2f} "
        f"lat={a.lateral:+5.2f}/{b.lateral:+5.2f} h={a.heading:+.2f}/{b.heading:+.2f}"
    )
    faults = [int(world.istate[0, k, st.I_FAULTS]) for k in range(2)]
    for k in range(2):
        if faults[k] > last[k]:
            print(f"FAULT kart {k} at t={(step + 1) * DT:.2f}")
            print("\n".join(history[-40::4]))
    last[:] = faults


spec = RaceSpec(track=track, controllers=("mcts-lqng", opponent), seed=seed, start_lanes=lanes, start_spread=spread)
out = run_race(spec, drivers=[make_controller("mcts-lqng"), make_controller(opponent)], on_step=hook)
print([(round(k.finish_time or 0, 2), k.collisions_at_fault, k.passes) for k in out.result.karts])
