"""Every 0.1 s between T0 and T1: the checkpoints passed, whether kart 0 (mcts-lqng) is on a straight, the gap
along the centre line (m, + = kart 0 behind), speeds, lateral offsets and the collisions at fault so far, in a
race of mcts-lqng against fixed-lqng from a spread start. TRACK (default complex-reversed), SPREAD (default 0.25).
argv: seed t0 t1.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session21/variants/contact_trace.py 9 6.5 10.0
"""

import os
import sys

from controllers.race import RaceSpec, load_any_track, run_race
from sim_core.observation import observe
from sim_core.params import DT

track = os.environ.get("TRACK", "complex-reversed")
spread = float(os.environ.get("SPREAD", "0.25"))
seed = int(sys.argv[1])
t0 = float(sys.argv[2])
t1 = float(sys.argv[3])
circuit = load_any_track(track)


def hook(world, drivers, step):
    t = (step + 1) * DT
    if step % 5 or not t0 <= t <= t1:
        return
    a, b = observe(world, 0)[0].karts[:2]
    res = world.result(0)
    straight = int(circuit.section_is_straight(a.checkpoints_passed))
    faults = [k.collisions_at_fault for k in res.karts]
    print(
        f"t={t:6.2f} cp={a.checkpoints_passed}/{b.checkpoints_passed} str={straight} "
        f"gap={circuit.gap(a.progress, b.progress):+5.2f} v={a.speed:5.2f}/{b.speed:5.2f} "
        f"lat={a.lateral:+5.2f}/{b.lateral:+5.2f} f={faults}"
    )


spec = RaceSpec(
    track=track,
    controllers=("mcts-lqng", "fixed-lqng"),
    seed=seed,
    start_lanes=(2, 3) if seed % 2 == 0 else (3, 2),
    start_spread=spread,
)
run_race(spec, on_step=hook)
