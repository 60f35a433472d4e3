"""How closely does each registered agent drive the racing line? (session 28)

mcts-lqng as registered races OPPONENT on TRACK from both start lanes; every second the other kart's lateral
offset is compared with the racing line's (``optimise_racing_line``, what fixed-lqng drives) at its progress, and its
speed with the line's speed there. Printed per opponent: the mean and 90th percentile of |offset error| [m] and of
|speed error| [m/s], over seconds where the karts are more than 8 m apart (clear of the trackers' game) and all.

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session28/line_fit.py --track complex
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from controllers.race import RaceSpec, run_race
from controllers.racing_line import optimise_racing_line
from sim_core.observation import observe
from sim_core.world import World


def samples(track: str, opponent: str, lanes: tuple[int, int], seed: int) -> list[tuple[float, float, float, float]]:
    rows: list[tuple[float, float, float, float]] = []
    line = None

    def hook(world: World, drivers: object, step: int) -> None:
        nonlocal line
        if line is None:
            line = optimise_racing_line(world.track, world.params.kart)
        if step % 50:
            return
        obs = observe(world, 0)[0]
        other = next(iter(obs.others()), None)
        if other is None or obs.time < 1.0:
            return
        me = obs.me
        distance = float(np.hypot(other.x - me.x, other.y - me.y))
        offset_error = other.lateral - float(line.offset_at(other.progress))
        speed_error = other.speed - float(line.speed_at(other.progress))
        rows.append((obs.time, distance, offset_error, speed_error))

    run_race(RaceSpec(track, ("mcts-lqng", opponent), seed=seed, start_lanes=lanes), on_step=hook)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--track", default="complex")
    ap.add_argument("--opponents", default="fixed-lqng,mcts-lqng,e2e,fixed-rl,mcts-rl")
    args = ap.parse_args()
    out = {}
    for opponent in args.opponents.split(","):
        rows = np.array(samples(args.track, opponent, (2, 3), 0) + samples(args.track, opponent, (3, 2), 1))
        clear = rows[rows[:, 1] > 8.0]
        entry = {}
        for name, part in (("clear", clear), ("all", rows)):
            off, spd = np.abs(part[:, 2]), np.abs(part[:, 3])
            entry[name] = {
                "n": len(part),
                "offset_mean": round(float(off.mean()), 3),
                "offset_p90": round(float(np.percentile(off, 90)), 3),
                "speed_mean": round(float(spd.mean()), 3),
                "speed_p90": round(float(np.percentile(spd, 90)), 3),
            }
        # the first seconds: what a gate would see before the first corner
        early = rows[rows[:, 0] <= 6.0]
        entry["first_6s_offset"] = [round(float(v), 2) for v in early[:, 2]]
        entry["first_6s_speed"] = [round(float(v), 2) for v in early[:, 3]]
        out[opponent] = entry
        print(opponent, json.dumps(entry), flush=True)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
