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
from numba import njit
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


def most_probable_pedal_of(mean: float, std: float) -> float:
    """:func:`most_probable_pedal` of one Gaussian, the same arithmetic on floats (a decision of one kart costs
    a microsecond here where the array functions' calls cost fifty)."""
    sigma = max(std, 1e-9)
    brake = float(ndtr((-1.0 / 3.0 - mean) / sigma))
    accelerate = 1.0 - float(ndtr((1.0 / 3.0 - mean) / sigma))
    coast = 1.0 - brake - accelerate
    if brake > coast and brake > accelerate:
        return -1.0
    return 1.0 if accelerate > coast else 0.0


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
    (..., 2) of karts at ``speed`` (...).

    The steer is clipped to [-1, 1]; the pedal's branch asks for :func:`branch_acceleration`, turned into a
    throttle by :meth:`KartParams.throttle_for_acceleration`; a held brake from standstill (or while rolling
    back) reverses (throttle -1), as the original's ArcadeKart: the only way off a wall the kart has stopped
    against. NaN actions count as 0."""
    a = np.asarray(action, dtype=np.float64)
    flat = np.ascontiguousarray(a).reshape(-1, 2)
    speeds = np.asarray(speed, dtype=np.float64)
    if speeds.shape != a.shape[:-1]:
        speeds = np.broadcast_to(speeds, a.shape[:-1])
    speeds = np.ascontiguousarray(speeds).reshape(-1)
    out = np.empty(flat.shape)
    branch = np.empty(flat.shape[0], dtype=np.int64)
    _world_actions(
        flat, speeds, kart.top_speed, kart.low_speed_gain, kart.acceleration, kart.braking, kart.coasting_drag,
        out, branch,
    )  # fmt: skip
    return out.reshape(a.shape), branch.reshape(a.shape[:-1])


# One compiled loop for every kart: the training batch maps 256 actions per decision, where ~30 numpy calls
# cost more than the arithmetic. The same operations in the same order as the array functions above (and
# KartParams.throttle_for_acceleration), so the actions are bit-identical to composing them.
_LARGEST = float(np.finfo(np.float64).max)


@njit(cache=True, inline="always")
def _finite(x: float) -> float:
    """``np.nan_to_num(x, nan=0.0)`` of one float."""
    if np.isnan(x):
        return 0.0
    if np.isinf(x):
        return _LARGEST if x > 0.0 else -_LARGEST
    return x


@njit(cache=True, inline="always")
def _clip_unit(x: float) -> float:
    """``np.clip(x, -1, 1)`` of one float (NaN stays NaN)."""
    return -1.0 if x < -1.0 else (1.0 if x > 1.0 else x)


@njit(cache=True, error_model="numpy")
def _world_actions(
    action: np.ndarray,
    speed: np.ndarray,
    top_speed: float,
    low_speed_gain: float,
    acceleration: float,
    braking: float,
    drag: float,
    out: np.ndarray,
    branch: np.ndarray,
) -> None:
    for n in range(action.shape[0]):
        pedal = _finite(action[n, 1])
        b = BRAKE if pedal < -1.0 / 3.0 else (ACCELERATE if pedal > 1.0 / 3.0 else COAST)
        branch[n] = b
        out[n, 0] = _clip_unit(_finite(action[n, 0]))
        v = speed[n]
        ratio = np.abs(v) / top_speed
        ratio = ratio if ratio <= 1.0 or np.isnan(ratio) else 1.0  # np.minimum(ratio, 1.0)
        curve = low_speed_gain + (1.0 - low_speed_gain) * ratio * ratio
        accel = -braking * curve if b == BRAKE else (acceleration * curve if b == ACCELERATE else -drag)
        accel = _finite(accel)
        if accel >= -drag:
            throttle = (accel + drag) / (acceleration * curve + drag)
        else:
            throttle = (accel + drag) / (braking * curve - drag)
        if v <= 1e-3 and accel <= 0.0:
            throttle = 0.0
        throttle = _clip_unit(throttle)
        out[n, 1] = -1.0 if b == BRAKE and v <= STANDSTILL else throttle
