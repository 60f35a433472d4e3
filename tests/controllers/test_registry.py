"""Contract of every registered controller, and a seeded headless race through the registry."""

from __future__ import annotations

import math

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
def test_every_controller_resets_and_acts(name: str, track_name: str) -> None:
    # the time per decision (budget 0.5 s) is measured by benchmarks/decision_time.py: timings on a shared
    # machine are no test
    track = get_track(track_name)
    world = World(track, 1, 2, SimParams())
    driver = make_controller(name)
    assert isinstance(driver, Controller)
    assert REGISTRY[name].description
    driver.reset(RaceContext(track, world.params.kart, 0, 2, world.lane_change_limit, seed=1))
    for _ in range(120):
        obs = observe(world, 0)[0]
        action = driver.act(obs)
        assert -1.0 <= action.steer <= 1.0 and -1.0 <= action.throttle <= 1.0
        assert math.isfinite(action.steer) and math.isfinite(action.throttle)
        world.step(np.array([[[action.steer, action.throttle], [0.0, 0.5]]]))
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
