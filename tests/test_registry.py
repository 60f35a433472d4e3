"""Contract of every registered controller, and a seeded headless race through the registry."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from controllers.base import Controller, RaceContext
from controllers.race import RaceSpec, run_race
from controllers.registry import REGISTRY, controller_names, make_controller
from sim_core.observation import observe
from sim_core.params import SimParams
from sim_core.track_io import get_track
from sim_core.world import World


@pytest.mark.parametrize("name", controller_names())
@pytest.mark.parametrize("track_name", ["oval", "complex", "train-oval-small-reversed"])
def test_every_controller_resets_and_acts_within_budget(name: str, track_name: str) -> None:
    track = get_track(track_name)
    world = World(track, 1, 2, SimParams())
    driver = make_controller(name)
    assert isinstance(driver, Controller)
    assert REGISTRY[name].description
    driver.reset(RaceContext(track, world.params.kart, 0, 2, world.lane_change_limit, seed=1))
    slowest = 0.0
    for step in range(120):
        obs = observe(world, 0)[0]
        t0 = time.perf_counter()
        action = driver.act(obs)
        if step > 0:  # the first call may compile and plan
            slowest = max(slowest, time.perf_counter() - t0)
        assert -1.0 <= action.steer <= 1.0 and -1.0 <= action.throttle <= 1.0
        assert math.isfinite(action.steer) and math.isfinite(action.throttle)
        world.step(np.array([[[action.steer, action.throttle], [0.0, 0.5]]]))
    assert slowest < 0.5, f"{name} took {slowest:.3f} s for one decision"
    assert world.speeds[0, 0] > 3.0, f"{name} did not drive off"


def test_unknown_controller_is_refused_by_name() -> None:
    with pytest.raises(KeyError, match="unknown controller 'nope'"):
        make_controller("nope")
    with pytest.raises(KeyError):
        make_controller("controllers.registry.LaneFollowerController")


def test_a_seeded_headless_race_is_deterministic() -> None:
    spec = RaceSpec(track="train-oval-small", controllers=("mcts-lqng", "fixed-lqng"), laps=1, seed=4)
    first = run_race(spec, record=True)
    second = run_race(spec, record=True)
    assert first.result == second.result
    assert first.replay is not None and second.replay is not None
    assert first.replay.poses == second.replay.poses
    assert all(k.finished for k in first.result.karts)
    assert first.result.karts[0].delta_r is not None  # the planner's targets reached the referee
