"""Training episodes as the original's ``ENV.ResetGame`` in Training mode: random spawns and random plans.

* Head-to-head spawn with probability 6/9: the other karts within +-1 checkpoint of the first, in distinct
  lanes; otherwise every kart at a random checkpoint.
* Random lane, 1-4 m past the checkpoint; with probability 0.3 1 m from a side wall instead of on a lane
  (optionally turned toward it by up to ``near_wall_heading``: ours, to learn to back off a wall).
* Tyre wear ~ U[0, 0.95]; the kart behind finds the checkpoints the leader passed already reached, at random
  earlier times (so it is scored second there).
* No tree search: ``planRandomly`` fills the plan with the racing lane moved by round(|N(0, 1)|) lanes and a
  speed of 15 (Fixed-RL) or 15 - |N(0, 1.5)| (MCTS-RL); E2E has no plan (checkpoint centres, top speed).
"""

from __future__ import annotations

import numpy as np

from controllers.rl.config import EnvConfig
from sim_core import state as st
from sim_core.track import Track
from sim_core.world import World

MAX_SPAWN_WEAR = 0.95


def clear_race(world: World, race: int) -> None:
    """Zero every counter of one race (as :meth:`World.reset` does) without re-sensing the other races."""
    world.clear_race(race)


def racing_lane_at_checkpoints(track: Track) -> np.ndarray:
    """(N,) the racing lane targeted at each checkpoint (section i's lane is the target at checkpoint i + 1)."""
    lanes = np.array([lane if lane is not None else 2 for lane in track.racing_lanes], dtype=np.int64)
    return np.roll(lanes, 1)


def random_plan(
    config: EnvConfig, track: Track, top_speed: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """(lane per checkpoint (N,), 0 = the centre; speed per checkpoint (N,) [m/s]) for one kart's episode."""
    n = track.n_checkpoints
    if config.agent == "e2e":
        return np.zeros(n, dtype=np.int64), np.full(n, top_speed)
    shift = np.rint(np.abs(rng.standard_normal(n))).astype(np.int64) * rng.choice([-1, 1], size=n)
    lanes = racing_lane_at_checkpoints(track) + shift
    lanes = np.where(lanes < 1, 2 - lanes, lanes)  # reflect off the outer lanes
    lanes = np.where(lanes > track.n_lanes, 2 * track.n_lanes - lanes, lanes)
    lanes = np.clip(lanes, 1, track.n_lanes)
    if config.agent == "fixed-rl":
        return lanes, np.full(n, top_speed)
    return lanes, top_speed - np.abs(rng.normal(0.0, config.mcts_speed_sigma, size=n))


def spawn_checkpoints(config: EnvConfig, n_checkpoints: int, rng: np.random.Generator) -> np.ndarray:
    """(K,) absolute checkpoint index each kart spawns past (may be -1: the lap before)."""
    k = config.n_karts
    first = int(rng.integers(n_checkpoints))
    if rng.random() < config.head_to_head_probability:
        return np.array([first] + [first + int(rng.integers(-1, 2)) for _ in range(k - 1)], dtype=np.int64)
    return np.array([first] + [int(rng.integers(n_checkpoints)) for _ in range(k - 1)], dtype=np.int64)


def spawn_race(world: World, race: int, config: EnvConfig, rng: np.random.Generator) -> np.ndarray:
    """Clear race ``race`` and place its karts at random (the caller re-senses). Returns the (K,) absolute
    checkpoint index each kart spawned past."""
    track = world.track
    n = track.n_checkpoints
    clear_race(world, race)
    cps = spawn_checkpoints(config, n, rng)
    lanes = rng.permutation(np.arange(1, track.n_lanes + 1))
    for k, cp in enumerate(cps):
        c = int(cp) % n
        s = float(track.checkpoint_s[c] + rng.uniform(*config.spawn_ahead))
        lane = int(lanes[k % len(lanes)])
        d = float(track.lane_offsets(c)[lane - 1])
        heading = 0.0
        if rng.random() < config.near_wall_probability:
            left, right = track.half_widths_at(s)
            d = left - 1.0 if rng.random() < 0.5 else -(right - 1.0)
            # turned toward that wall by up to the configured angle (left-positive, like d)
            if config.near_wall_heading > 0.0:  # (no extra draw otherwise: older seeded runs replay)
                heading = float(np.sign(d) * rng.uniform(0.0, config.near_wall_heading))
        wear = float(rng.uniform(0.0, MAX_SPAWN_WEAR))
        world.place_kart(race, k, s=s, d=d, heading_offset=heading, wear=wear)
        # the kart's spawn progress decides its checkpoint count; keep the lap the absolute index implies
        world.istate[race, k, st.I_CP_PASSED] = cp
    return cps
