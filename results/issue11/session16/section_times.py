"""Section times of two controllers, each alone on a track from lane 3 (seed 0), laps 2 and 3.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session16/section_times.py complex mcts-lqng,fixed-lqng

Prints, per section (checkpoint c to c + 1, from the second lap on): both karts' times, the running difference
a - b [s], the speeds and the lateral offsets at the section's end.
"""

from __future__ import annotations

import sys

from controllers.race import RaceSpec, run_race
from sim_core.observation import observe
from sim_core.params import DT
from sim_core.world import World


def crossings(track: str, controller: str) -> dict[int, tuple[float, float, float]]:
    """Time, speed and lateral offset of a solo kart when it first counts each checkpoint."""
    seen: dict[int, tuple[float, float, float]] = {}

    def hook(world: World, drivers: object, step: int) -> None:
        me = observe(world, 0)[0].karts[0]
        seen.setdefault(me.checkpoints_passed, ((step + 1) * DT, me.speed, me.lateral))

    run_race(RaceSpec(track=track, controllers=(controller,), seed=0, start_lanes=(3,)), on_step=hook)
    return seen


def main(track: str, pair: str) -> None:
    """Print the section table of the two comma-separated controllers."""
    a_name, b_name = pair.split(",")
    a, b = crossings(track, a_name), crossings(track, b_name)
    n_checkpoints = 41 if track == "complex" else min(a)  # complex's count; sections start on lap 2
    print("cp  c  dt_a  dt_b  diff(cum)  v_a  v_b  lat_a lat_b")
    total = 0.0
    for c in range(n_checkpoints + 1, min(max(a), max(b))):
        if not all(k in d for k in (c, c + 1) for d in (a, b)):
            continue
        dt_a, dt_b = a[c + 1][0] - a[c][0], b[c + 1][0] - b[c][0]
        total += dt_a - dt_b
        print(
            f"{c:3d} {c % n_checkpoints:2d} {dt_a:5.2f} {dt_b:5.2f} {total:+6.2f}  "
            f"{a[c + 1][1]:5.1f} {b[c + 1][1]:5.1f}  {a[c + 1][2]:+5.2f} {b[c + 1][2]:+5.2f}"
        )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
