"""Headless races: the launch delays of a spread start (``RaceSpec.start_spread``)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from controllers.race import MAX_START_SPREAD, RaceSpec, run_race
from sim_core.observation import observe
from sim_core.params import DT


def test_without_a_spread_every_kart_launches_at_once() -> None:
    assert RaceSpec(seed=3).start_delays() == (0.0, 0.0)


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), spread=st.floats(0.01, MAX_START_SPREAD))
def test_launch_delays_lie_in_the_spread_and_depend_on_the_seed_alone(seed: int, spread: float) -> None:
    tactical = RaceSpec(controllers=("mcts-lqng", "fixed-lqng"), seed=seed, start_spread=spread)
    control = RaceSpec(controllers=("fixed-lqng", "fixed-lqng"), seed=seed, start_spread=spread, start_lanes=(3, 2))
    delays = tactical.start_delays()
    assert len(delays) == 2
    assert all(0.0 <= d < spread for d in delays)
    assert control.start_delays() == delays  # a paired comparison: the same starts for any drivers
    assert RaceSpec(controllers=tactical.controllers, seed=seed + 1, start_spread=spread).start_delays() != delays


@pytest.mark.parametrize("spread", [-0.1, MAX_START_SPREAD + 0.1])
def test_a_spread_outside_its_range_is_refused(spread: float) -> None:
    with pytest.raises(ValueError, match="start_spread"):
        RaceSpec(start_spread=spread)


def test_each_kart_stands_until_its_delay_and_then_drives() -> None:
    spec = RaceSpec(
        track="oval", controllers=("fixed-lqng", "fixed-lqng"), seed=5, start_spread=1.0, time_limit=2.0, laps=1
    )
    delays = spec.start_delays()
    assert abs(delays[0] - delays[1]) > 0.1  # this seed launches them apart
    speeds: list[tuple[float, ...]] = []

    def watch(world, drivers, step) -> None:  # type: ignore[no-untyped-def]
        speeds.append(tuple(o.me.speed for o in observe(world, 0)))

    outcome = run_race(spec, on_step=watch)
    assert outcome.start_delays == delays
    for k, delay in enumerate(delays):
        waited = [v[k] for step, v in enumerate(speeds) if (step + 1) * DT <= delay]
        assert waited and max(waited) == 0.0
        moving = [v[k] for step, v in enumerate(speeds) if (step + 1) * DT >= delay + 0.2]
        assert min(moving) > 0.5
    first, second = sorted(range(2), key=lambda k: delays[k])
    assert speeds[round(delays[second] / DT) - 1][first] > 0.0
