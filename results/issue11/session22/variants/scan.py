"""Races of mcts-lqng (kart 0) against OPP with its tracker's settings overridden, in parallel: one line per race
(winner, finish times, collisions at fault by each kart, contacts, passes) and the moments mcts-lqng's collisions at
fault rose. TRACKER: a JSON object of ``LQNGParams`` fields set on mcts-lqng's tracker ({} = as shipped); BASE:
``close`` starts from ``CLOSE_FOLLOWING_TRACKING``. argv: track opponent seeds (e.g. 0-7 or 0,3,5) [workers].

    TRACKER='{"follow_predict_time": 0.4}' PYTHONPATH=$PWD .venv/bin/python \\
        results/issue11/session22/variants/scan.py complex fixed-rl 0-3 2
"""

import json
import os
import sys
from dataclasses import replace
from multiprocessing import Pool

import sim_core.state as st
from controllers.lq.tracker import CLOSE_FOLLOWING_TRACKING
from controllers.race import RaceSpec, load_any_track, run_race
from controllers.registry import make_controller
from sim_core.observation import observe
from sim_core.params import DT


def seeds_of(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(x) for x in text.split(",")]


def race(args: tuple[str, str, int]) -> str:
    track, opponent, seed = args
    circuit = load_any_track(track)
    overrides = json.loads(os.environ.get("TRACKER", "{}"))
    opp_kwargs = json.loads(os.environ.get("OPP_PARAMS", "{}"))
    mine = make_controller("mcts-lqng")
    base = CLOSE_FOLLOWING_TRACKING if os.environ.get("BASE") == "close" else mine.tracker.params
    mine.tracker.params = replace(base, horizon=mine.tracker.params.horizon, **overrides)
    lanes = (2, 3) if seed % 2 == 0 else (3, 2)
    last = [0, 0]
    notes: list[str] = []

    def hook(world, drivers, step):
        faults = [int(world.istate[0, k, st.I_FAULTS]) for k in range(2)]
        if faults[0] > last[0]:
            a, b = observe(world, 0)[0].karts[:2]
            notes.append(
                f"  fault t={(step + 1) * DT:.2f} cp={a.checkpoints_passed}/{b.checkpoints_passed} "
                f"gap={circuit.gap(a.progress, b.progress):+.2f} v={a.speed:.2f}/{b.speed:.2f} "
                f"lat={a.lateral:+.2f}/{b.lateral:+.2f}"
            )
        last[:] = faults

    spread = float(os.environ.get("SPREAD", "0"))
    spec = RaceSpec(track=track, controllers=("mcts-lqng", opponent), seed=seed, start_lanes=lanes, start_spread=spread)
    out = run_race(spec, drivers=[mine, make_controller(opponent, **opp_kwargs)], on_step=hook)
    a, b = out.result.karts
    won = (a.finish_time or 1e9) < (b.finish_time or 1e9)
    line = (
        f"{track} {opponent} seed={seed} lane={lanes[0]} won={int(won)} "
        f"t={a.finish_time or 0:.2f}/{b.finish_time or 0:.2f} "
        f"faults={a.collisions_at_fault}/{b.collisions_at_fault} passes={a.passes}/{b.passes}"
    )
    return "\n".join([line, *notes])


if __name__ == "__main__":
    track, opponent, seeds = sys.argv[1], sys.argv[2], seeds_of(sys.argv[3])
    workers = int(sys.argv[4]) if len(sys.argv) > 4 else 2
    settings = {name: os.environ.get(name, default) for name, default in (("TRACKER", "{}"), ("BASE", "default"))}
    print("# " + " ".join(f"{name}={value}" for name, value in settings.items()))
    wins = faults = 0
    with Pool(workers) as pool:
        for text in pool.imap(race, [(track, opponent, s) for s in seeds]):
            print(text, flush=True)
            first = text.split("\n")[0]
            wins += int(first.split("won=")[1].split()[0])
            faults += int(first.split("faults=")[1].split("/")[0])
    print(f"# summary {track} {opponent} races={len(seeds)} mcts-lqng wins={wins} faults={faults}")
