"""Widening a trained actor to races of more karts: the column map by hand, and the widened actor acting as the
narrow one whatever the added opponents show."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from controllers.rl.config import STACK
from controllers.rl.observations import OPPONENT_FEATURES, frame_size, widened_columns
from controllers.rl.policy import load_policy, weights_folder
from controllers.rl.train import widen_first_layer


def test_two_karts_widened_to_three_keep_own_opponent_targets_and_rays_in_order() -> None:
    source, added = widened_columns(2, 3, stack=1)
    assert frame_size(2) == 55 and frame_size(3) == 67 and source.shape == (67,)
    assert source[:21].tolist() == list(range(21))  # own (9) and the one opponent (12)
    assert source[21:33].tolist() == list(range(9, 21)) and added[21:33].all()  # the new one: the first's stats
    assert source[33:].tolist() == list(range(21, 55)) and not added[33:].any()  # targets and rays
    stacked, stacked_added = widened_columns(2, 3, stack=STACK)
    assert stacked[67 + 33] == 55 + 21 and stacked_added.sum() == STACK * OPPONENT_FEATURES


def test_widening_needs_at_least_as_many_karts() -> None:
    with pytest.raises(ValueError, match="widen"):
        widened_columns(4, 2, stack=STACK)


@pytest.mark.parametrize("karts", [3, 4, 8])
def test_a_widened_actor_acts_as_the_shipped_one_whatever_the_added_opponents_show(karts: int) -> None:
    narrow = load_policy(weights_folder("e2e"))
    width = STACK * frame_size(karts)
    w0, mean, var = widen_first_layer(narrow.weights[0], narrow.obs_mean, narrow.obs_var, width)
    wide = replace(narrow, weights=(w0, *narrow.weights[1:]), obs_mean=mean, obs_var=var)
    source, added = widened_columns(2, karts, STACK)
    rng = np.random.default_rng(3)
    for _ in range(5):
        obs = narrow.obs_mean + rng.standard_normal(narrow.obs_size) * np.sqrt(narrow.obs_var)
        wide_obs = obs[source]
        wide_obs[added] = rng.uniform(-50.0, 50.0, int(added.sum()))  # anything: a kart anywhere
        np.testing.assert_allclose(wide.mean(wide_obs), narrow.mean(obs), rtol=0, atol=1e-12)


def test_an_actor_of_no_race_size_is_refused() -> None:
    with pytest.raises(ValueError, match="cannot widen"):
        widen_first_layer(np.zeros((128, 221)), np.zeros(221), np.ones(221), STACK * frame_size(4))
