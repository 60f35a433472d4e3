"""Each appendix reward term against a hand-built situation."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from controllers.rl import rewards as rw
from controllers.rl.config import WALL_THRESHOLDS, RewardWeights, override_weights
from sim_core.state import HIT_KART, HIT_NONE, HIT_WALL

W = RewardWeights()
FAR = 20.0


def rays(index: int, distance: float, kind: int) -> tuple[np.ndarray, np.ndarray]:
    d = np.full(9, FAR)
    h = np.full(9, HIT_NONE)
    d[index], h[index] = distance, kind
    return d, h


def test_a_wall_ray_at_half_a_metre_costs_exactly_one_ray_penalty() -> None:
    for j, h in enumerate(WALL_THRESHOLDS):
        d, k = rays(j, 0.5, HIT_WALL)
        assert rw.wall_hit_penalty(W.wall_hit, d, k) == -W.wall_hit
        d, k = rays(j, h + 1e-6, HIT_WALL)  # just outside that ray's own threshold
        assert rw.wall_hit_penalty(W.wall_hit, d, k) == 0.0
    d, k = rays(4, 0.5, HIT_KART)  # a kart is not a wall
    assert rw.wall_hit_penalty(W.wall_hit, d, k) == 0.0


def test_player_hit_front_rays_pay_the_at_fault_extra() -> None:
    d, k = rays(0, 1.0, HIT_KART)  # straight ahead
    assert rw.player_hit_penalty(4.5, 2.0, d, k) == -6.5
    d, k = rays(4, 1.0, HIT_KART)  # +90 deg: beside, not at fault
    assert rw.player_hit_penalty(4.5, 2.0, d, k) == -4.5
    d, k = rays(0, 1.6, HIT_KART)  # beyond 1.5 m
    assert rw.player_hit_penalty(4.5, 2.0, d, k) == 0.0
    assert rw.hit_by_player_penalty(3.5, np.array(2.0)) == -7.0


def test_speed_and_direction() -> None:
    assert rw.speed_reward(1.0, np.array(7.5), 15.0) == 0.5
    assert rw.speed_reward(1.0, np.array(-3.0), 15.0) == pytest.approx(-0.2)
    pos, target = np.array([0.0, 0.0]), np.array([10.0, 0.0])
    assert rw.direction_reward(0.008, pos, np.array(0.0), np.array(5.0), target) == pytest.approx(0.008)
    assert rw.direction_reward(0.008, pos, np.array(np.pi / 2), np.array(5.0), target) == pytest.approx(0.0)
    assert rw.direction_reward(0.008, pos, np.array(np.pi), np.array(5.0), target) == pytest.approx(-0.008)
    assert rw.direction_reward(0.008, pos, np.array(0.0), np.array(0.0), target) == 0.0


def test_step_constants_and_swerve() -> None:
    assert rw.acceleration_reward(0.002, np.array([1.0, 0.0])).tolist() == [0.002, 0.0]
    assert rw.not_at_goal_penalty(0.001, np.array([True, False])).tolist() == [-0.001, 0.0]
    assert rw.swerve_penalty(15.0, np.array([0, 1, 2])).tolist() == [0.0, -15.0, -30.0]


def test_checkpoint_order_time_and_behind() -> None:
    order = np.array([0, 1, 2, 3, 5])
    assert rw.checkpoint_base_reward(2.0, order).tolist() == [2.0, 1.5, 1.2, 0.8, 0.8]
    assert rw.checkpoint_time_reward(20.0, np.array(0), np.array(15.0), 30.0) == 10.0
    assert rw.checkpoint_time_reward(20.0, np.array(1), np.array(15.0), 30.0) == 7.5
    assert rw.behind_opponent_penalty(0.06, np.array(50.0)) == pytest.approx(-3.0)
    assert rw.behind_opponent_penalty(0.06, np.array(0.0)) == 0.0


def test_checkpoint_target_lane_and_speed() -> None:
    assert rw.target_lane_reward(4.0, np.array(1.3)) == 4.0
    assert rw.target_lane_reward(4.0, np.array(2.0)) == pytest.approx(4.0 / 1.69)
    assert rw.target_speed_reward(4.0, np.array(0.4), scaled=True) == 4.0
    assert rw.target_speed_reward(4.0, np.array(-3.0), scaled=True) == pytest.approx(4.0 / 1.1**3)
    assert rw.target_speed_reward(4.0, np.array(-3.0), scaled=False) == 4.0


def test_reverse() -> None:
    assert rw.reverse_penalty(10.0, np.array(0)) == -10.0
    assert rw.reverse_penalty(10.0, np.array(2)) == -30.0
    assert rw.reverse_penalty(10.0, np.array(-1)) == 0.0


def test_override_weights_sets_the_named_terms_and_keeps_the_rest() -> None:
    changed = override_weights(W, ["target_lane=0", "checkpoint-time=40.5"])
    assert changed.target_lane == 0.0 and changed.checkpoint_time == 40.5
    assert replace(changed, target_lane=W.target_lane, checkpoint_time=W.checkpoint_time) == W


@pytest.mark.parametrize(
    ("assignment", "message"),
    [
        ("bogus=1", "NAME one of"),
        ("target_lane", "NAME=VALUE"),
        ("speed=fast", "not a number"),
        ("swerve=-1", "non-negative"),
        ("swerve=nan", "non-negative"),
    ],
)
def test_override_weights_rejects_what_is_not_a_weight(assignment: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        override_weights(W, [assignment])
