"""The action map: pedal thirds, the most likely branch of a Gaussian, reversing from standstill."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as hs
from scipy.stats import norm

from controllers.rl.actions import (
    ACCELERATE,
    BRAKE,
    COAST,
    branch_acceleration,
    most_probable_pedal,
    pedal_branch,
    world_actions,
)
from sim_core.kart import STANDSTILL
from sim_core.params import kart_preset


def test_pedal_thirds() -> None:
    assert list(pedal_branch(np.array([-1.0, -0.34, -0.33, 0.0, 0.33, 0.34, 1.0, np.nan]))) == [
        BRAKE,
        BRAKE,
        COAST,
        COAST,
        COAST,
        ACCELERATE,
        ACCELERATE,
        COAST,
    ]


def test_most_probable_pedal_hand_checked() -> None:
    # mean 0.3 (the coasting third) with std 0.4: P(accelerate) = 1 - Phi(0.0833) = 0.467, P(coast) =
    # Phi(0.0833) - Phi(-1.583) = 0.476: coast, barely; with std 0.5 accelerate wins (0.473 vs 0.424)
    assert most_probable_pedal(np.array(0.3), np.array(0.4)) == 0.0
    assert most_probable_pedal(np.array(0.3), np.array(0.5)) == 1.0
    assert most_probable_pedal(np.array(-0.9), np.array(0.3)) == -1.0
    assert most_probable_pedal(np.array(0.0), np.array(0.01)) == 0.0


@given(hs.floats(-2.0, 2.0), hs.floats(0.01, 2.0))
def test_most_probable_pedal_is_the_argmax_of_the_branch_masses(mean: float, std: float) -> None:
    brake = norm.cdf(-1 / 3, mean, std)
    accelerate = norm.sf(1 / 3, mean, std)
    masses = [brake, 1.0 - brake - accelerate, accelerate]
    pedal = float(most_probable_pedal(np.array(mean), np.array(std)))
    assert masses[int(pedal) + 1] >= max(masses) - 1e-9


def test_brake_from_standstill_reverses_and_brake_at_speed_slows() -> None:
    kart = kart_preset("paper")
    speeds = np.array([0.0, -1.0, 8.0])
    action = np.array([[0.0, -1.0]] * 3)
    out, branch = world_actions(kart, speeds, action)
    assert list(branch) == [BRAKE] * 3
    assert out[0, 1] == -1.0 and out[1, 1] == -1.0
    assert out[2, 1] < 0.0  # braking at speed: a negative throttle that slows, never the reverse gear's hold
    coast, _ = world_actions(kart, np.array([0.0]), np.array([[0.0, 0.0]]))
    assert coast[0, 1] == 0.0


def reference_world_actions(kart_name: str, speed: np.ndarray, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The action map composed of its array functions and the kart's own inverse."""
    kart = kart_preset(kart_name)
    a = np.nan_to_num(np.asarray(action, dtype=float), nan=0.0)
    branch = pedal_branch(a[..., 1])
    out = np.empty(a.shape)
    out[..., 0] = np.clip(a[..., 0], -1.0, 1.0)
    throttle = kart.throttle_for_acceleration(speed, branch_acceleration(kart, speed, branch))
    out[..., 1] = np.where((branch == BRAKE) & (speed <= STANDSTILL), -1.0, throttle)
    return out, branch


def test_compiled_action_map_equals_the_array_functions_bit_for_bit() -> None:
    """Every branch, standstill, rolling back, above top speed, out-of-range and non-finite actions."""
    rng = np.random.default_rng(3)
    speed = np.concatenate([rng.uniform(-4.0, 20.0, 3000), [0.0, 1e-3, 2e-3, -1e-3, 1e-4, 40.0]])
    speed = np.resize(speed, (6, 501))
    action = rng.uniform(-1.5, 1.5, (6, 501, 2))
    action.reshape(-1)[rng.choice(action.size, 40, replace=False)] = [np.nan, np.inf, -np.inf, 1 / 3, -1 / 3] * 8
    for name in ("paper", "original"):
        got, got_branch = world_actions(kart_preset(name), speed, action)
        want, want_branch = reference_world_actions(name, speed, action)
        assert got.shape == want.shape and np.array_equal(got, want, equal_nan=True)
        assert np.array_equal(got_branch, want_branch)
    assert {BRAKE, COAST, ACCELERATE} == set(np.unique(want_branch))
    one, branch = world_actions(kart_preset("paper"), np.array([0.0]), np.array([[0.2, -0.9]]))
    assert one.shape == (1, 2) and branch.shape == (1,) and one[0, 1] == -1.0 and branch[0] == BRAKE
