"""The action map: the original's action space (continuous steer, brake / coast / accelerate) to World inputs.

Stable-Baselines3's PPO has no hybrid (continuous + discrete) action space, so an action is a Box of two:
``[steer, pedal]`` in [-1, 1]. ``pedal`` picks one of the original's three branches by thirds (brake below
-1/3, accelerate above +1/3, coast between). The branch becomes a throttle through the kart's own longitudinal
model (:meth:`sim_core.params.KartParams.throttle_for_acceleration`): accelerate asks for the kart's full
acceleration at its speed, coast for the coasting drag (throttle 0), brake for its full braking; from standstill
a held brake reverses (throttle -1), as the original's ArcadeKart.
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr

from sim_core.kart import STANDSTILL
from sim_core.params import KartParams

BRAKE, COAST, ACCELERATE = 0, 1, 2


def pedal_branch(pedal: np.ndarray) -> np.ndarray:
    """0 = brake, 1 = coast, 2 = accelerate, from the pedal action in [-1, 1] (NaN coasts)."""
    p = np.nan_to_num(np.asarray(pedal, dtype=float), nan=0.0)
    return np.where(p < -1.0 / 3.0, BRAKE, np.where(p > 1.0 / 3.0, ACCELERATE, COAST))


def most_probable_pedal(mean: np.ndarray, std: np.ndarray) -> np.ndarray:
    """The pedal of the branch the Gaussian N(``mean``, ``std``) most likely picks: -1 (brake), 0 (coast) or
    +1 (accelerate).

    The deterministic counterpart of a discrete branch's argmax (what ML-Agents' deterministic inference does
    with the original's 3-way branch). The Gaussian's mean alone is not: a mean just inside the coasting third,
    with most of the mass above +1/3, would coast where the trained policy almost always accelerates.
    """
    mu = np.asarray(mean, dtype=float)
    sigma = np.maximum(np.asarray(std, dtype=float), 1e-9)
    brake = ndtr((-1.0 / 3.0 - mu) / sigma)
    accelerate = 1.0 - ndtr((1.0 / 3.0 - mu) / sigma)
    coast = 1.0 - brake - accelerate
    return np.select([(brake > coast) & (brake > accelerate), accelerate > coast], [-1.0, 1.0], default=0.0)


def branch_acceleration(kart: KartParams, speed: np.ndarray, branch: np.ndarray) -> np.ndarray:
    """[m/s^2] the longitudinal acceleration each branch asks of the kart at ``speed``."""
    ratio = np.minimum(np.abs(np.asarray(speed, dtype=float)) / kart.top_speed, 1.0)
    curve = kart.low_speed_gain + (1.0 - kart.low_speed_gain) * ratio * ratio
    return np.select(
        [branch == BRAKE, branch == ACCELERATE],
        [-kart.braking * curve, kart.acceleration * curve],
        default=-kart.coasting_drag,
    )


def world_actions(kart: KartParams, speed: np.ndarray, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(World actions ``[steer, throttle]`` with the shape of ``action``, the pedal branch) for ``action``
    (..., 2) of karts at ``speed`` (...)."""
    a = np.nan_to_num(np.asarray(action, dtype=float), nan=0.0)
    branch = pedal_branch(a[..., 1])
    out = np.empty(a.shape)
    out[..., 0] = np.clip(a[..., 0], -1.0, 1.0)
    throttle = kart.throttle_for_acceleration(speed, branch_acceleration(kart, speed, branch))
    # a held brake from standstill (or while rolling back) reverses, as the original's ArcadeKart: the only way
    # off a wall the kart has stopped against
    reversing = (branch == BRAKE) & (np.asarray(speed, dtype=float) <= STANDSTILL)
    out[..., 1] = np.where(reversing, -1.0, throttle)
    return out, branch
