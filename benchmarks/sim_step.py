"""Simulation step throughput with sensors and referee on.

Measures (1) steps/s of one 2-kart race stepped one step per call, as the live server and a headless race
do, and (2) kart-steps/s of B = 1024 two-kart races stepped together, as training does. Both use the
``complex`` track (the more expensive one) with karts driving a lane at race speed, so walls, rays and
checkpoints are exercised. Run from the repo root: ``.venv/bin/python benchmarks/sim_step.py`` (``--help``: the
sizes; the smoke test runs it tiny). The last line printed is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from controllers.lane_follower import LaneFollower
from sim_core.track_io import get_track
from sim_core.world import World

TRACK = "complex"
SINGLE_STEPS = 20_000
BATCH = 1024
BATCH_STEPS = 400


def driving_actions(world: World, follower: LaneFollower) -> np.ndarray:
    """Actions of a lane-following driver for every kart (computed once per controller update)."""
    lateral = np.where(np.arange(world.n_karts) % 2 == 0, 1.25, -1.25)[None, :]
    return follower.act_on(world, lateral)


def bench_single(track_name: str, n_steps: int = SINGLE_STEPS) -> float:
    track = get_track(track_name)
    world = World(track, 1, 2)
    follower = LaneFollower(track, world.params.kart)
    world.step()  # compile
    world.reset()
    steps = 0
    elapsed = 0.0
    while steps < n_steps:
        actions = driving_actions(world, follower)  # a new decision every 10 steps, not timed
        t0 = time.perf_counter()
        for _ in range(10):
            world.step(actions)
        elapsed += time.perf_counter() - t0
        steps += 10
        if world.done[0]:
            world.reset()
    return steps / elapsed


def bench_batched(track_name: str, batch: int = BATCH, n_steps: int = BATCH_STEPS) -> float:
    track = get_track(track_name)
    world = World(track, batch, 2)
    follower = LaneFollower(track, world.params.kart)
    # spread the races around the lap so the batch sees straights and curves alike
    rng = np.random.default_rng(0)
    for b in range(batch):
        s = rng.uniform(0, track.length)
        world.place_kart(b, 0, s, 1.25, speed=8.0)
        world.place_kart(b, 1, s - 6.0, -1.25, speed=8.0)
    world.step(np.zeros((batch, 2, 2)))  # compile
    elapsed = 0.0
    for _ in range(max(1, n_steps // 10)):
        actions = driving_actions(world, follower)
        t0 = time.perf_counter()
        world.step(actions, n_steps=10)
        elapsed += time.perf_counter() - t0
    return batch * 2 * max(1, n_steps // 10) * 10 / elapsed


def main() -> None:
    """Time both ways of stepping; print a line each, then the JSON summary."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--single-steps", type=int, default=SINGLE_STEPS, help="steps of the single race timed")
    parser.add_argument("--batch", type=int, default=BATCH, help="races stepped together")
    parser.add_argument("--batch-steps", type=int, default=BATCH_STEPS, help="steps of the batch timed")
    args = parser.parse_args()
    single = bench_single(TRACK, args.single_steps)
    batched = bench_batched(TRACK, args.batch, args.batch_steps)
    print(f"single 2-kart race on {TRACK}: {single:,.0f} steps/s ({single * 0.02:,.0f}x real time)")
    print(f"batched {args.batch} x 2 karts on {TRACK}: {batched:,.0f} kart-steps/s")
    print(
        json.dumps(
            {
                "track": TRACK,
                "single_race_steps_per_s": round(single),
                "single_race_realtime_factor": round(single * 0.02, 1),
                "batched_kart_steps_per_s": round(batched),
                "batch_size": args.batch,
                "targets": {"single_race_steps_per_s": 20000, "batched_kart_steps_per_s": 1000000},
            }
        )
    )


if __name__ == "__main__":
    main()
