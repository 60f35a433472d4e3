"""The batched world: many races on one track advanced by one compiled call, as training and tournaments use it.

From the repo root::

    .venv/bin/python examples/01_batched_world.py                     # 256 races x 2 karts on the oval
    .venv/bin/python examples/01_batched_world.py --races 1024 --karts 4 --track complex

``World(track, n_races=B, n_karts=K)`` holds every kart's state in packed (B, K, ...) arrays (column indices
in :mod:`sim_core.state`); ``world.step(actions)`` takes (B, K, 2) ``[steer, throttle]`` inputs and advances
every race by 0.02 s (physics, contacts, referee and the 9 range rays). A race stepped alone is bit-identical
to the same race inside a batch. Here a vectorised pure-pursuit driver
(:class:`~controllers.lane_follower.LaneFollower`) drives every kart of every race at once, each race with
its karts on different lanes, until all races are done.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from controllers.lane_follower import LaneFollower
from sim_core import state as st
from sim_core.params import DT
from sim_core.track_io import get_track
from sim_core.world import World

DECISION_STEPS = 5  # the driver decides every 5 steps (10 Hz); the world holds its inputs in between


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--track", default="oval")
    parser.add_argument("--races", type=int, default=256)
    parser.add_argument("--karts", type=int, default=2)
    parser.add_argument("--laps", type=int, default=1)
    args = parser.parse_args()

    track = get_track(args.track)
    world = World(track, n_races=args.races, n_karts=args.karts, laps=args.laps)
    world.reset()  # every race on the starting grid, lanes 2, 3, 1, 4 (then a second row)
    driver = LaneFollower(track, world.params.kart)
    # each kart follows a lane: race b puts kart k on lane (b + k) mod 4, so the races differ
    offsets = np.array([track.lane_offsets(0)[(b + np.arange(args.karts)) % track.n_lanes] for b in range(args.races)])

    wall = time.perf_counter()
    steps = 0
    while not world.done.all():
        actions = driver.act(
            world.positions,  # (B, K, 2)
            world.headings,
            world.speeds,
            world.fstate[:, :, st.F_S],  # progress along the lap
            world.fstate[:, :, st.F_WEAR],
            offsets,
        )
        world.step(actions, n_steps=DECISION_STEPS)
        steps += DECISION_STEPS
    wall = time.perf_counter() - wall

    kart_steps = args.races * args.karts * steps
    print(
        f"{args.races} races x {args.karts} karts on {track.name}, {args.laps} lap(s): {steps * DT:.1f} s of racing "
        f"in {wall:.2f} s ({kart_steps / wall:,.0f} kart-steps/s, compile included)"
    )
    results = [world.result(b) for b in range(args.races)]
    winners = [r.winner for r in results]
    times = [k.finish_time for r in results for k in r.karts if k.finish_time is not None]
    print(f"finishers: {len(times)} of {args.races * args.karts}; fastest {min(times, default=float('nan')):.2f} s")
    for k in range(args.karts):
        print(f"  kart {k} won {winners.count(k)} races")
    print(f"race 0, kart 0: rays [m] {np.round(world.ray_dist[0, 0], 1).tolist()}")


if __name__ == "__main__":
    main()
