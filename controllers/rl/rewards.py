"""The reward terms of the paper's appendix ("Reward Structure Formulation"), one function per term.

Every function is vectorised: arrays of any leading shape (races, karts) in, the reward of that term out.
Weights are positive (:class:`controllers.rl.config.RewardWeights`); penalties carry their minus sign here.
Equation names are the appendix's; where the original code (``../shared/spec/original_implementation.md``
section 6) differs from the printed equation, the code's form is used and the docstring says how.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from controllers.rl.config import (
    DECISION_STEPS,
    FRONT_RAYS,
    LANE_DEADZONE,
    OPPONENT_THRESHOLD,
    POSITION_FACTORS,
    SPEED_BIN,
    WALL_THRESHOLDS,
    RewardWeights,
)
from controllers.rl.observations import TrackTables
from sim_core import state as st
from sim_core.params import DT
from sim_core.state import HIT_KART, HIT_WALL
from sim_core.world import World

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


# ---------------------------------------------------------------- the training batch's sums, compiled
# The training batch scores every race of a World each decision. As numpy over ~20 races per track the terms
# cost ~40 array calls per track, most of the environment's step; these loops compute the same terms with the
# same arithmetic, operation by operation and in the same order (libm's cos/sin/hypot/pow, no fused
# multiply-add), so the rewards are bit-identical to composing the functions above.
DECISION_TERMS: tuple[str, ...] = (
    "speed",
    "direction",
    "acceleration",
    "not_at_goal",
    "swerve",
    "wall_hit",
    "player_hit",
    "hit_by_player",
)


def decision_terms(
    weights: RewardWeights,
    top_speed: float,
    world: World,
    points: np.ndarray,
    plan_lane: np.ndarray,
    accelerating: np.ndarray,
    active: np.ndarray,
    last_illegal: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The per-decision terms of every kart of ``world`` ((len(DECISION_TERMS), B, K), in that order) and their
    sum over the ``active`` karts (B, K): the per-step terms times the 2 steps a decision holds, the swerve
    penalty of the illegal lane changes since ``last_illegal``, the ray terms of the rays now. The direction
    term aims at the next checkpoint's target point (``points`` (N, lanes + 1, 2) under ``plan_lane``)."""
    f = world.fstate
    terms = np.empty((len(DECISION_TERMS), f.shape[0], f.shape[1]))
    total = np.empty(f.shape[:2])
    w = np.array(
        [
            weights.speed,
            weights.direction,
            weights.acceleration,
            weights.not_at_goal,
            weights.swerve,
            weights.wall_hit,
            weights.player_hit,
            weights.player_hit_front,
            weights.hit_by_player,
        ]
    )
    _decision_terms(
        w, float(top_speed), f, world.istate, world.ray_dist, world.ray_hit, points, plan_lane,
        np.asarray(accelerating, dtype=np.float64), np.asarray(active, dtype=np.bool_), last_illegal,
        WALL_THRESHOLD_ARRAY, FRONT_RAY_MASK, terms, total,
    )  # fmt: skip
    return terms, total


@njit(cache=True)
def _maximum(a: float, b: float) -> float:
    """``np.maximum`` of two floats (NaN first wins, ``a`` on a tie)."""
    return a if a >= b or np.isnan(a) else b


@njit(cache=True)
def _found_kart(f: np.ndarray, b: int, k: int) -> int:
    """The kart that kart ``k``'s rays found: the other one of two, else the nearest other kart (np.argmin of
    the gaps: the first smallest, or the first NaN)."""
    n_karts = f.shape[1]
    if n_karts == 2:
        return 1 - k
    j, gap = 0, np.inf
    for m in range(n_karts):
        d = np.inf
        if m != k:
            d = np.hypot(f[b, k, st.F_X] - f[b, m, st.F_X], f[b, k, st.F_Y] - f[b, m, st.F_Y])
        if np.isnan(d):
            return m
        if d < gap:
            j, gap = m, d
    return j


@njit(cache=True)
def _decision_terms(
    w: np.ndarray,
    top: float,
    f: np.ndarray,
    i: np.ndarray,
    ray_dist: np.ndarray,
    ray_hit: np.ndarray,
    points: np.ndarray,
    plan_lane: np.ndarray,
    accelerating: np.ndarray,
    active: np.ndarray,
    last_illegal: np.ndarray,
    wall_h: np.ndarray,
    front: np.ndarray,
    terms: np.ndarray,
    total: np.ndarray,
) -> None:
    n_races, n_karts, n_rays = ray_dist.shape
    n = points.shape[0]
    hits = np.zeros(n_karts)  # rays of each kart that found another kart within the threshold
    for b in range(n_races):
        for k in range(n_karts):
            walls = players = fronts = 0
            for r in range(n_rays):
                d, h = ray_dist[b, k, r], ray_hit[b, k, r]
                if d < wall_h[r] and h == HIT_WALL:
                    walls += 1
                if d < OPPONENT_THRESHOLD and h == HIT_KART:
                    players += 1
                    if front[r]:
                        fronts += 1
            hits[k] = players
            speed = f[b, k, st.F_SPEED]
            c = (i[b, k, st.I_CP_PASSED] + 1) % n
            lane = plan_lane[b, k, c]
            dx, dy = points[c, lane, 0] - f[b, k, st.F_X], points[c, lane, 1] - f[b, k, st.F_Y]
            course = f[b, k, st.F_HEADING] + f[b, k, st.F_SLIP]
            cos = (np.cos(course) * dx + np.sin(course) * dy) / _maximum(np.hypot(dx, dy), 1e-9)
            terms[0, b, k] = DECISION_STEPS * (w[0] * speed / top)
            terms[1, b, k] = DECISION_STEPS * (w[1] * cos * np.sign(speed))
            terms[2, b, k] = DECISION_STEPS * (w[2] * accelerating[b, k])
            terms[3, b, k] = DECISION_STEPS * (-w[3] * (1.0 if active[b, k] else 0.0))
            terms[4, b, k] = -w[4] * float(i[b, k, st.I_ILLEGAL_STEP] - last_illegal[b, k])
            terms[5, b, k] = -w[5] * float(walls)
            terms[6, b, k] = -(w[6] * float(players) + w[7] * float(fronts))
        # each kart's hits charged to the kart they found: the other one of two, else the nearest other kart
        for k in range(n_karts):
            terms[7, b, k] = 0.0
        for k in range(n_karts):
            j = _found_kart(f, b, k)
            terms[7, b, j] += hits[k]
        for k in range(n_karts):
            terms[7, b, k] = -w[8] * terms[7, b, k]
            acc = 0.0
            for t in range(terms.shape[0]):
                acc = acc + (terms[t, b, k] if active[b, k] else 0.0)
            total[b, k] = acc


def checkpoint_terms(
    weights: RewardWeights,
    scaled_speed: bool,
    horizon: float,
    world: World,
    tables: TrackTables,
    plan_lane: np.ndarray,
    plan_speed: np.ndarray,
    active: np.ndarray,
    last_passed: np.ndarray,
    last_since: np.ndarray,
    reach_count: np.ndarray,
    first_time: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(reward (B, K), checkpoints passed (B, K), metres since the last one (B, K)) of the terms scored on passing
    a checkpoint since ``last_passed`` and of the reverse penalty (back over the last one: ``last_since`` under
    half a lap, now over it). Kart by kart, as two karts may reach one checkpoint in one decision: the first
    there sets ``first_time`` (B, M), each one counts in ``reach_count`` (B, M), both updated in place.
    ``scaled_speed``: the target-speed term scales by D_vel (MCTS-RL)."""
    f, i = world.fstate, world.istate
    passed = i[:, :, st.I_CP_PASSED].copy()
    since = np.mod(f[:, :, st.F_S] - tables.checkpoint_s[np.mod(passed, tables.n_checkpoints)], tables.length)
    out = np.empty(passed.shape)
    w = np.array(
        [
            weights.reverse,
            weights.checkpoint_base,
            weights.checkpoint_time,
            weights.behind_opponent,
            weights.target_lane,
            weights.target_speed,
        ]
    )
    _checkpoint_terms(
        w, scaled_speed, float(horizon), float(tables.length), f, passed, since, tables.offsets, plan_lane,
        plan_speed, np.asarray(active, dtype=np.bool_), last_passed, last_since, reach_count, first_time,
        np.asarray(POSITION_FACTORS), out,
    )  # fmt: skip
    return out, passed, since


@njit(cache=True)
def _checkpoint_terms(
    w: np.ndarray,
    scaled: bool,
    horizon: float,
    length: float,
    f: np.ndarray,
    passed: np.ndarray,
    since: np.ndarray,
    offsets: np.ndarray,
    plan_lane: np.ndarray,
    plan_speed: np.ndarray,
    active: np.ndarray,
    last_passed: np.ndarray,
    last_since: np.ndarray,
    reach_count: np.ndarray,
    first_time: np.ndarray,
    factors: np.ndarray,
    out: np.ndarray,
) -> None:
    n_races, n_karts = passed.shape
    n, last_m = offsets.shape[0], reach_count.shape[1] - 1
    for b in range(n_races):
        for k in range(n_karts):
            back = active[b, k] and passed[b, k] == last_passed[b, k]
            back = back and last_since[b, k] < length / 2 and since[b, k] > length / 2
            out[b, k] = 0.0 + (-w[0] * (0.0 + 1.0) if back else 0.0)
            if not (active[b, k] and passed[b, k] > last_passed[b, k]):
                continue
            m = min(max(passed[b, k] + 1, 0), last_m)
            order = reach_count[b, m]
            time = f[b, k, st.F_CROSS_TIME]
            first = time if order == 0 else first_time[b, m]
            first_time[b, m] = first
            reach_count[b, m] += 1
            c = passed[b, k] % n
            lane_miss = np.abs(f[b, k, st.F_D] - offsets[c, plan_lane[b, k, c]])
            speed_miss = np.abs(f[b, k, st.F_CROSS_SPEED] - plan_speed[b, k, c])
            factor = factors[min(order, len(factors) - 1)]
            lane_reward = w[4] / (1.0 if lane_miss <= LANE_DEADZONE else np.power(1.3, lane_miss))
            speed_reward = w[5]
            if scaled:
                speed_reward = w[5] / (1.0 if speed_miss <= SPEED_BIN / 2 else np.power(1.1, speed_miss))
            out[b, k] += (
                w[1] * factor
                + w[2] * factor * (horizon - time) / horizon
                + -w[3] * _maximum((time - first) / DT, 0.0)
                + lane_reward
                + speed_reward
            )
