"""Training spawns: near-wall spawns, turned toward the wall when asked."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from controllers.rl.envs import make_config
from controllers.rl.spawns import random_plan, spawn_race
from sim_core import state as st
from sim_core.geometry import wrap_angle
from sim_core.params import SimParams
from sim_core.track_io import get_track
from sim_core.world import World


def _spawns(heading_deg: float, n: int = 60) -> list[tuple[float, float]]:
    """(lateral offset, heading relative to the track) of kart 0 over ``n`` seeded near-wall spawns."""
    track = get_track("train-oval-large")
    config = replace(make_config("e2e"), near_wall_probability=1.0, near_wall_heading=np.radians(heading_deg))
    world = World(track, 1, 2, SimParams())
    rng = np.random.default_rng(7)
    out = []
    for _ in range(n):
        spawn_race(world, 0, config, rng)
        s, d = world.fstate[0, 0, st.F_S], world.fstate[0, 0, st.F_D]
        _, tangent = track.point_at(float(s))
        relative = wrap_angle(world.fstate[0, 0, st.F_HEADING] - np.arctan2(tangent[1], tangent[0]))
        out.append((float(d), float(relative)))
    return out


def test_near_wall_spawns_are_a_metre_from_a_wall_and_along_the_track_by_default() -> None:
    for d, relative in _spawns(0.0):
        assert abs(abs(d) - 4.0) < 1e-6  # the training ovals are 10 m wide: 1 m from a wall
        assert abs(relative) < 1e-9


def test_near_wall_spawns_turn_toward_their_wall_up_to_the_limit() -> None:
    spawns = _spawns(60.0)
    for d, relative in spawns:
        assert np.sign(relative) == np.sign(d) or relative == 0.0  # left wall: turned left (counter-clockwise)
        assert abs(relative) <= np.radians(60.0) + 1e-9
    assert max(abs(r) for _, r in spawns) > np.radians(40.0)  # the range is used, not a fixed angle


def test_mcts_rl_training_plans_ask_for_the_spec_speeds_or_top_speed_everywhere() -> None:
    """The spec's 15 - |N(0, 1.5)| m/s per waypoint by default; with ``mcts_speed_sigma`` 0 top speed at every
    waypoint, the speed mcts-rl's planner sends at race time with no kart ahead (``karting train
    --mcts-speed-sigma``). Fixed-RL's plans are at top speed either way."""
    track = get_track("train-oval-small")
    rng = np.random.default_rng(0)
    config = make_config("mcts-rl")
    _, speeds = random_plan(config, track, 15.0, rng)
    assert np.all(speeds <= 15.0) and np.mean(speeds) < 14.5
    _, flat = random_plan(replace(config, mcts_speed_sigma=0.0), track, 15.0, rng)
    assert np.all(flat == 15.0)
    _, fixed = random_plan(make_config("fixed-rl"), track, 15.0, rng)
    assert np.all(fixed == 15.0)
