"""A headless race between registered controllers, faster than real time, and the referee's result.

From the repo root::

    .venv/bin/python examples/00_headless_race.py                                   # MCTS-LQNG vs Fixed-LQNG, oval
    .venv/bin/python examples/00_headless_race.py --track complex-reversed --laps 1 --replay race.json

A race is named by a :class:`~controllers.race.RaceSpec` (track, controllers by registered name, laps, seed,
start lanes) and run to the end by :func:`~controllers.race.run_race`: every kart finished, or the 120 s limit.
The same seed gives the same race. ``karting race`` is the same thing with a table.
"""

from __future__ import annotations

import argparse

from controllers.race import RaceSpec, run_race
from controllers.registry import controller_names


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--track", default="oval", help="a built-in track (karting tracks), or a track JSON")
    parser.add_argument("--karts", default="mcts-lqng,fixed-lqng", help=f"comma-separated, of {controller_names()}")
    parser.add_argument("--laps", type=int, default=None, help="laps (default: the track's)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--replay", default=None, help="write the replay (poses, inputs, plans) as JSON here")
    args = parser.parse_args()

    spec = RaceSpec(track=args.track, controllers=tuple(args.karts.split(",")), laps=args.laps, seed=args.seed)
    outcome = run_race(spec, record=args.replay is not None)
    result = outcome.result
    print(f"{spec.track}: {result.duration:.2f} s of racing simulated in {outcome.wall_seconds:.2f} s")
    for kart in sorted(result.karts, key=lambda k: k.position):
        finish = f"{kart.finish_time:7.2f} s" if kart.finish_time is not None else "    DNF"
        print(
            f"  {kart.position}. kart {kart.kart + 1} {spec.controllers[kart.kart]:<14} {finish}  "
            f"collisions at fault {kart.collisions_at_fault}, illegal lane changes {kart.illegal_lane_changes}, "
            f"safety score {kart.safety_score}"
        )
    winner = result.winner
    # karts are numbered from 1 where people read (kart.kart is the 0-based grid slot)
    print(f"winner: {'nobody' if winner is None else f'kart {winner + 1} ({spec.controllers[winner]})'}")
    if args.replay is not None and outcome.replay is not None:
        outcome.replay.save(args.replay)
        print(f"replay written to {args.replay}")


if __name__ == "__main__":
    main()
