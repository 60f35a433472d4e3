"""mcts-lqng (kart 0) against fixed-lqng from a spread start: the applied tactical plans whose searched ego
waypoints stop short of the horizon (``Plan.padded`` > 0), up to three per race, then the race's finish times,
collisions at fault and passes. argv: track spread first last (races first..last-1) or track spread seeds
(comma separated).

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session23/variants/short_plans.py complex 0.5 15,52,99
"""

import sys
from multiprocessing import Pool

from controllers.race import RaceSpec, run_race
from sim_core.observation import observe
from sim_core.params import DT


def one(args: tuple[str, float, int]) -> list[str]:
    track, spread, index = args
    lanes = (2, 3) if index % 2 == 0 else (3, 2)
    notes: list[str] = []
    applied = [0, 0]

    def hook(world, drivers, step):
        views = observe(world, 0)[0].karts
        for k, driver in enumerate(drivers):
            if getattr(driver, "plans_applied", 0) == applied[k]:
                continue
            applied[k] = driver.plans_applied
            plan = driver.active_plan
            if plan is None or plan.iterations == 0 or not plan.padded:
                continue
            me, other = views[k], views[1 - k]
            notes.append(
                f"race {index} t={(step + 1) * DT:.2f} kart {k} searched={len(plan.ego_waypoints) - plan.padded} "
                f"padded={plan.padded} cp={me.checkpoints_passed}/{other.checkpoints_passed} "
                f"v={me.speed:.2f}/{other.speed:.2f} "
                f"waypoints={[(w.checkpoint, w.lane, round(w.speed, 1)) for w in plan.ego_waypoints]}"
            )

    spec = RaceSpec(
        track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=index, start_lanes=lanes, start_spread=spread
    )
    out = run_race(spec, on_step=hook)
    a, b = out.result.karts
    delays = "/".join(f"{d:.3f}" for d in out.start_delays)
    return [
        *notes[:3],
        f"race {index} delays {delays} times {a.finish_time} / {b.finish_time} "
        f"faults {a.collisions_at_fault}/{b.collisions_at_fault} passes {a.passes}/{b.passes}",
    ]


def main() -> None:
    track, spread = sys.argv[1], float(sys.argv[2])
    if len(sys.argv) == 4:
        races = [int(x) for x in sys.argv[3].split(",")]
    else:
        races = list(range(int(sys.argv[3]), int(sys.argv[4])))
    with Pool(2) as pool:
        for lines in pool.imap(one, [(track, spread, i) for i in races]):
            print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()
