"""The reward terms of the paper's appendix ("Reward Structure Formulation"), one function per term.

Every function is vectorised: arrays of any leading shape (races, karts) in, the reward of that term out.
Weights are positive (:class:`controllers.rl.config.RewardWeights`); penalties carry their minus sign here.
Equation names are the appendix's; where the original code (``../shared/spec/original_implementation.md``
section 6) differs from the printed equation, the code's form is used and the docstring says how.
"""

from __future__ import annotations

import numpy as np

from controllers.rl.config import (
    FRONT_RAYS,
    LANE_DEADZONE,
    OPPONENT_THRESHOLD,
    POSITION_FACTORS,
    SPEED_BIN,
    WALL_THRESHOLDS,
)
from sim_core.state import HIT_KART, HIT_WALL

WALL_THRESHOLD_ARRAY = np.asarray(WALL_THRESHOLDS)
FRONT_RAY_MASK = np.isin(np.arange(len(WALL_THRESHOLDS)), FRONT_RAYS)


# ---------------------------------------------------------------- every time step
def speed_reward(weight: float, speed: np.ndarray, top_speed: float) -> np.ndarray:
    """R_speed(w1) = w1 v / v_max (signed: reversing is negative, as the original's LocalSpeed)."""
    return weight * np.asarray(speed) / top_speed


def direction_reward(
    weight: float, position: np.ndarray, course: np.ndarray, speed: np.ndarray, target: np.ndarray
) -> np.ndarray:
    """R_direction(w1): w1 times the cosine between the velocity and the direction to the next target r*.

    The appendix prints the dot product; the original code (TowardsCheckpointReward) uses the cosine, which is
    what keeps the term bounded. ``position``/``target`` (..., 2) [m], ``course`` the direction of travel [rad]
    (heading + slip), ``speed`` [m/s] (a reversing kart's velocity points backwards; a stopped kart scores 0).
    """
    to_target = np.asarray(target) - np.asarray(position)
    norm = np.maximum(np.hypot(to_target[..., 0], to_target[..., 1]), 1e-9)
    cos = (np.cos(course) * to_target[..., 0] + np.sin(course) * to_target[..., 1]) / norm
    return weight * cos * np.sign(speed)


def acceleration_reward(weight: float, accelerating: np.ndarray) -> np.ndarray:
    """AccelerationReward (original code, not in the appendix): w for each step on the accelerator."""
    return weight * np.asarray(accelerating, dtype=float)


def not_at_goal_penalty(weight: float, active: np.ndarray) -> np.ndarray:
    """NotAtGoalPenalty (original code, not in the appendix): -w for each step a kart is still racing."""
    return -weight * np.asarray(active, dtype=float)


def swerve_penalty(weight: float, illegal_lane_changes: np.ndarray) -> np.ndarray:
    """R_swerve(w1) = -w1 1[(x, y) in S and e > L], once per illegal lane change as the referee counts it
    (``sim_core.state.I_ILLEGAL_STEP``: every lane change as it happens, eqs. (10)-(11))."""
    return -weight * np.asarray(illegal_lane_changes, dtype=float)


def wall_hit_penalty(weight: float, ray_distance: np.ndarray, ray_hit: np.ndarray) -> np.ndarray:
    """R_wall-hit(w1) = -sum_j w1 1[I_j < h_j and ray j hit a wall], with the original's per-ray thresholds
    h_j (:data:`controllers.rl.config.WALL_THRESHOLDS`). ``ray_*`` (..., 9)."""
    near = (np.asarray(ray_distance) < WALL_THRESHOLD_ARRAY) & (np.asarray(ray_hit) == HIT_WALL)
    return -weight * near.sum(axis=-1)


def player_rays(ray_distance: np.ndarray, ray_hit: np.ndarray) -> np.ndarray:
    """(..., 9) bool: rays that found another kart within the opponent threshold (1.5 m)."""
    return (np.asarray(ray_distance) < OPPONENT_THRESHOLD) & (np.asarray(ray_hit) == HIT_KART)


def player_hit_penalty(weight: float, front_weight: float, ray_distance: np.ndarray, ray_hit: np.ndarray) -> np.ndarray:
    """R_player-hit(w1, w2) = -sum_j (w1 1[I_j < h and ray j hit a player] + w2 1[... and j in Theta]):
    every ray within 1.5 m of another kart costs w1, a front ray (Theta: 0 and +-30 deg, the at-fault side)
    costs w2 more."""
    hits = player_rays(ray_distance, ray_hit)
    return -(weight * hits.sum(axis=-1) + front_weight * (hits & FRONT_RAY_MASK).sum(axis=-1))


def hit_by_player_penalty(weight: float, rays_on_me: np.ndarray) -> np.ndarray:
    """HitByOpponentPenalty (original code; the other side of R_player-hit): -w for each ray of another kart
    that found this kart within 1.5 m."""
    return -weight * np.asarray(rays_on_me, dtype=float)


# ---------------------------------------------------------------- on passing a checkpoint
def position_factor(order: np.ndarray) -> np.ndarray:
    """k = 1, 0.75, 0.6, 0.4 for the 1st..4th kart to reach a checkpoint (0-based ``order``; later ones 0.4)."""
    factors = np.asarray(POSITION_FACTORS)
    return factors[np.minimum(np.asarray(order, dtype=np.int64), len(factors) - 1)]


def checkpoint_base_reward(weight: float, order: np.ndarray) -> np.ndarray:
    """R_checkpoint base(w1) = w1 if first, 0.75 w1 if second (0.6, 0.4 for third and fourth, as the code)."""
    return weight * position_factor(order)


def checkpoint_time_reward(weight: float, order: np.ndarray, time: np.ndarray, horizon: float) -> np.ndarray:
    """R_checkpoint time(w1) = w1 (T - t) / T, scaled by the same position factor k as the original's code
    (PassCheckpointTimeMultiplier k (maxSteps - t) / maxSteps). ``time`` t and ``horizon`` T in seconds."""
    return weight * position_factor(order) * (horizon - np.asarray(time)) / horizon


def behind_opponent_penalty(weight: float, steps_behind: np.ndarray) -> np.ndarray:
    """BeingBehindOpponentCheckpointPenalty (original code): -w per physics step the kart reached this
    checkpoint after the first kart that did (0 for the first)."""
    return -weight * np.maximum(np.asarray(steps_behind, dtype=float), 0.0)


def target_lane_reward(weight: float, lane_distance: np.ndarray) -> np.ndarray:
    """The lane half of R_checkpoint target(w1, w2): w1 / D_lane, D_lane = 1 within 1.3 m of the target lane
    point, else 1.3^distance (the original's code; the appendix prints 1.3^(|a - a'| distance))."""
    dist = np.asarray(lane_distance, dtype=float)
    return weight / np.where(dist <= LANE_DEADZONE, 1.0, np.power(1.3, dist))


def target_speed_reward(weight: float, speed_error: np.ndarray, scaled: bool) -> np.ndarray:
    """The speed half of R_checkpoint target(w1, w2): w2 / D_vel, D_vel = 1 within half a velocity bin of the
    target speed, else 1.1^|v - v'|. Only MCTS mode scales (``scaled``); Fixed-RL and E2E get w2 flat, as the
    original."""
    err = np.abs(np.asarray(speed_error, dtype=float))
    if not scaled:
        return np.full_like(err, weight)
    return weight / np.where(err <= SPEED_BIN / 2, 1.0, np.power(1.1, err))


def reverse_penalty(weight: float, checkpoints_back: np.ndarray) -> np.ndarray:
    """R_checkpoint reverse(w1) = -w1 1[r' <= r]: -w1 (checkpoints back + 1) for each crossing of a checkpoint
    already passed, driving the wrong way (``checkpoints_back`` = 0 for the last one passed)."""
    back = np.asarray(checkpoints_back, dtype=float)
    return np.where(back >= 0, -weight * (back + 1.0), 0.0)
