"""Race conditions (:mod:`sim_core.conditions`): draws in their ranges, a function of the seed alone, the named
sets, the imprecision noise's statistics and the grid they put karts on."""

from __future__ import annotations

import math
from typing import get_args

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim_core.conditions import (
    CONDITION_SETS,
    MAX_START_SPREAD,
    PAPER,
    VARIED,
    ConditionName,
    ConditionSet,
    Imprecision,
    RaceConditions,
    condition_set,
)
from sim_core.params import DT, RuleParams
from sim_core.state import F_S, F_WEAR
from sim_core.track_io import get_track
from sim_core.world import START_OFFSET, World


def test_paper_conditions_are_the_original_experiment() -> None:
    drawn = PAPER.draw(seed=123, n_karts=2)
    assert drawn.launch_delays == (0.0, 0.0) and drawn.start_offsets == (0.0, 0.0)
    assert drawn.start_wear == (RuleParams().start_wear,) * 2
    assert not drawn.imprecise and drawn.imprecision() is None


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), karts=st.integers(1, 8))
def test_varied_draws_lie_in_their_ranges_and_depend_on_the_seed_alone(seed: int, karts: int) -> None:
    drawn = VARIED.draw(seed, karts)
    assert drawn == VARIED.draw(seed, karts)  # one seed, one race
    assert len(drawn.launch_delays) == len(drawn.start_wear) == karts
    assert all(0.0 <= d < VARIED.start_spread for d in drawn.launch_delays)
    low, high = VARIED.wear_range
    assert all(low <= w < high for w in drawn.start_wear)
    other = VARIED.draw(seed + 1, karts)
    assert other.launch_delays != drawn.launch_delays and other.noise_seed != drawn.noise_seed
    assert RaceConditions.from_json(drawn.to_json()) == drawn


@pytest.mark.parametrize(
    "field, value",
    [("start_spread", MAX_START_SPREAD + 0.1), ("start_spread", -0.1), ("wear_range", (0.3, 0.2)),
     ("wear_range", (0.0, 1.0)), ("steer_noise", -0.01), ("throttle_noise", 0.9), ("noise_time", 0.0),
     ("grid", "diagonal"), ("stagger", 11.0)],
)  # fmt: skip
def test_a_value_out_of_range_is_refused_naming_it(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=field):
        ConditionSet("mine", **{field: value})  # type: ignore[arg-type]


def test_unknown_sets_are_refused_naming_the_known_ones() -> None:
    assert condition_set("varied") is VARIED and set(CONDITION_SETS) == set(get_args(ConditionName))
    with pytest.raises(KeyError, match="paper"):
        condition_set("wet")


def test_paces_are_drawn_per_kart_within_the_range_apart_from_the_other_draws() -> None:
    """varied-pace draws each kart's pace within [0.98, 1]: different karts, different races; and everything else
    as varied draws it (the pace has a stream of its own), so the two sets are paired race for race."""
    paced = [condition_set("varied-pace").draw(seed, 4) for seed in range(20)]
    plain = [VARIED.draw(seed, 4) for seed in range(20)]
    every = [p for race in paced for p in race.paces]
    assert all(0.98 <= p <= 1.0 for p in every) and len(set(every)) == len(every)
    assert all(race.paces == (1.0,) * 4 for race in plain)
    strip = {"name": None, "paces": None}
    assert [r.to_json() | strip for r in paced] == [r.to_json() | strip for r in plain]
    assert RaceConditions.from_json(paced[0].to_json()) == paced[0]
    old = paced[0].to_json()
    del old["paces"]  # a record from before paces were drawn
    assert RaceConditions.from_json(old).paces == (1.0,) * 4


def test_a_staggered_grid_puts_the_pole_in_lane_two_and_the_others_behind_it() -> None:
    grid = ConditionSet("staggered", grid="staggered", stagger=2.0)
    assert grid.start_offsets(2, (2, 3)) == (0.0, 2.0)
    assert grid.start_offsets(2, (3, 2)) == (2.0, 0.0)  # the lanes swapped: so is the pole
    assert grid.start_offsets(4) == (0.0, 2.0, 4.0, 6.0)
    world = World(get_track("oval"), 1, 2)
    drawn = grid.draw(0, 2, (3, 2))
    world.reset(start_lanes=(3, 2), wear=(0.2, 0.3), start_offsets=drawn.start_offsets)
    assert world.fstate[0, :, F_S].tolist() == pytest.approx([START_OFFSET - 2.0, START_OFFSET])
    assert world.fstate[0, :, F_WEAR].tolist() == pytest.approx([0.2, 0.3])


def test_a_world_refuses_a_wear_or_offset_per_kart_of_the_wrong_length() -> None:
    world = World(get_track("oval"), 1, 2)
    with pytest.raises(ValueError, match="each of the 2 karts"):
        world.reset(wear=(0.2, 0.2, 0.2))


def test_imprecision_is_a_stationary_noise_with_the_stated_deviation_and_correlation_time() -> None:
    noise = Imprecision(n_karts=400, steer=0.05, throttle=0.1, time=0.3, seed=7)
    zero = np.zeros((400, 2))
    driving = np.ones(400, dtype=bool)
    samples = np.array([noise.perturb(zero, driving) for _ in range(200)])  # (steps, karts, 2)
    assert samples[..., 0].std() == pytest.approx(0.05, rel=0.05)
    assert samples[..., 1].std() == pytest.approx(0.1, rel=0.05)
    lag = round(0.3 / DT)  # one correlation time: the autocorrelation falls to 1/e
    a, b = samples[:-lag, :, 0].ravel(), samples[lag:, :, 0].ravel()
    assert np.corrcoef(a, b)[0, 1] == pytest.approx(math.exp(-1.0), abs=0.05)


def test_imprecision_leaves_karts_that_do_not_drive_alone_and_keeps_commands_in_range() -> None:
    noise = Imprecision(n_karts=2, steer=0.3, throttle=0.3, time=0.3, seed=1)
    commands = np.array([[1.0, -1.0], [0.2, 0.5]])
    for _ in range(50):
        out = noise.perturb(commands, np.array([True, False]))
        assert np.all(np.abs(out) <= 1.0)
        assert out[1].tolist() == [0.2, 0.5]


def test_the_noise_stepped_in_blocks_is_the_noise_stepped_one_step_at_a_time() -> None:
    """The reference: one normal draw per step, the update written out."""
    noise = Imprecision(n_karts=3, steer=0.02, throttle=0.04, time=0.3, seed=11)
    rng = np.random.default_rng(11)
    sigma = np.array([0.02, 0.04])
    decay = math.exp(-DT / 0.3)
    state = rng.standard_normal((3, 2)) * sigma
    commands = np.zeros((3, 2))
    driving = np.ones(3, dtype=bool)
    for _ in range(2 * Imprecision.BLOCK + 5):  # across block boundaries
        state = decay * state + math.sqrt(1.0 - decay**2) * sigma * rng.standard_normal((3, 2))
        assert np.array_equal(noise.perturb(commands, driving), np.clip(state, -1.0, 1.0))
