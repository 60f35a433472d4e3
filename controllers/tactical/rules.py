"""Compiled rules of the discrete racing game: whose turn it is, which moves are legal and what they lead to
(the value of a finished game is :mod:`controllers.tactical.value`).

A game state is an int64 array of shape (players, N_FIELDS) plus the index of the last completed round.
Players move one checkpoint per round; within a round the player that reached the checkpoint first (the
smallest time state) moves first and the followers see its choice (paper section 4.1.2). The lane-change
rule is :func:`sim_core.rules.lane_change_update`, the very function the referee applies.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from controllers.tactical.game import GameTables
from controllers.tactical.motion import segment_time
from sim_core.kart import lateral_limit, tyre_wear, yaw_for_wear
from sim_core.rules import lane_change_update

# fields of a player's state
CHECKPOINT = 0  # absolute checkpoint index (not wrapped)
LANE = 1  # 0-based lane
BIN = 2  # velocity bin
TIME = 3  # [0.01 s] time state relative to the root's leader
WEAR = 4  # [1e-4] tyre wear
LANE_COUNT = 5  # eq. (10) gen_lane_var: recent lane changes on this contiguous straight or curve
PREV_LANE = 6  # 0-based lane at the previous checkpoint (to tell when two players' paths cross)
N_FIELDS = 7

NO_PLAYER = -1


@njit(cache=True)
def corner_speed(tb: GameTables, radius: float, wear_units: int) -> float:
    """Cornering speed [m/s] on ``radius`` [m] (0 = straight: top speed) at tyre wear ``wear_units``."""
    if radius <= 0.0:
        return tb.top_speed
    a_lat = lateral_limit(tb.kart, min(wear_units / 10_000.0, 1.0))
    return min(math.sqrt(a_lat * radius), tb.top_speed)


@njit(cache=True)
def worn_after(tb: GameTables, wear_units: int, yaw: float) -> int:
    """Tyre wear [1e-4] after turning through ``yaw`` [rad] more (the kart's exponential wear model)."""
    if yaw <= 0.0:
        return wear_units
    accumulated = yaw_for_wear(tb.kart, min(wear_units / 10_000.0, 0.999999))
    return max(int(tyre_wear(tb.kart, accumulated + yaw) * 10_000.0 + 0.5), wear_units)


@njit(cache=True)
def next_player(state: np.ndarray, round_checkpoint: int) -> int:
    """The player to move: among those still at ``round_checkpoint``, the one with the smallest time state.

    The player behind moves after the leader and sees its choice, so it is the one that must avoid the
    collision (the paper's rule of eqs. (8)-(9) gen_coll_avoid, section 4.1.2).
    """
    best = NO_PLAYER
    for p in range(state.shape[0]):
        if state[p, CHECKPOINT] == round_checkpoint and (best == NO_PLAYER or state[p, TIME] < state[best, TIME]):
            best = p
    return best


@njit(cache=True)
def move_outcome(tb: GameTables, state: np.ndarray, p: int, lane: int, vbin: int) -> tuple[int, int, int]:
    """(time after the move, new lane-change count, legal flag 0/1) of player ``p`` choosing ``lane``/``vbin``.

    Illegal: over the lane-change limit on a straight, arriving above the cornering speed, boundary
    conditions the 1-D motion cannot meet, arriving faster than the next section can brake from, and (when
    pruning is on) arriving within the collision window of a player who already reached that checkpoint this
    round, in its lane or on its other side (the paths cross).
    """
    n = tb.straight.shape[0]
    c = state[p, CHECKPOINT] % n
    here = state[p, LANE]
    # eq. (10) gen_lane_var (the counter) and eq. (11) gen_lane_lim (at most L changes on a straight)
    count, illegal = lane_change_update(
        state[p, LANE_COUNT], here, lane, tb.straight[c], tb.straight[(c + 1) % n], tb.lane_limit
    )
    if illegal:
        return 0, 0, 0
    radius = tb.corner_radius[c, here, lane]
    v_max = corner_speed(tb, radius, state[p, WEAR])
    if tb.bin_low[vbin] > v_max:
        return 0, 0, 0
    v0 = 0.5 * (tb.bin_low[state[p, BIN]] + tb.bin_high[state[p, BIN]])
    v1 = min(0.5 * (tb.bin_low[vbin] + tb.bin_high[vbin]), v_max)
    # entering above the corner speed means braking down to it first; segment_time handles that
    t = segment_time(tb.distance[c, here, lane], v0, v1, tb.accel, tb.brake, v_max)
    if t < 0.0:
        return 0, 0, 0
    # no arriving so fast that the next section cannot brake down to its own corner speed (a dead end)
    # (or into a lane from which no lane of the next section is reachable at the lowest speed bin)
    nxt = (c + 1) % n
    wear_then = worn_after(tb, state[p, WEAR], tb.turn_angle[c])
    entry = 0.0
    for j in range(tb.distance.shape[1]):
        _, blocked = lane_change_update(count, lane, j, tb.straight[nxt], tb.straight[(nxt + 1) % n], tb.lane_limit)
        v_next = corner_speed(tb, tb.corner_radius[nxt, lane, j], wear_then)
        if blocked or v_next < tb.bin_low[0]:
            continue
        entry = max(entry, math.sqrt(v_next * v_next + 2.0 * tb.brake * tb.distance[nxt, lane, j]))
    # the next move starts from the bin's middle speed, whatever the arrival was capped to
    if 0.5 * (tb.bin_low[vbin] + tb.bin_high[vbin]) > entry + 1e-9:
        return 0, 0, 0
    arrival = state[p, TIME] + int(t * 100.0 + 0.5)
    # eq. (8) gen_coll_avoid as the paper discretises it: no arrival close in time in the same lane or across a path
    if tb.collision_window > 0:
        target = state[p, CHECKPOINT] + 1
        for q in range(state.shape[0]):
            if q == p or state[q, CHECKPOINT] != target or abs(state[q, TIME] - arrival) >= tb.collision_window:
                continue
            # the same lane, or swapping sides with the other on the way (side by side, the paths cross)
            if state[q, LANE] == lane or (here - state[q, PREV_LANE]) * (lane - state[q, LANE]) < 0:
                return 0, 0, 0
    return arrival, count, 1


@njit(cache=True)
def legal_moves(tb: GameTables, state: np.ndarray, p: int, out: np.ndarray) -> int:
    """Write the legal actions (lane * bins + bin) of player ``p`` into ``out``; return how many."""
    bins = tb.bin_low.shape[0]
    lanes = tb.distance.shape[1]
    k = 0
    for lane in range(lanes):
        for vbin in range(bins):
            _, _, ok = move_outcome(tb, state, p, lane, vbin)
            if ok:
                out[k] = lane * bins + vbin
                k += 1
    return k


@njit(cache=True)
def apply_move(tb: GameTables, state: np.ndarray, p: int, action: int) -> bool:
    """Play ``action`` for player ``p`` in place; False (state unchanged) if it is illegal."""
    bins = tb.bin_low.shape[0]
    lane, vbin = action // bins, action % bins
    arrival, count, ok = move_outcome(tb, state, p, lane, vbin)
    if not ok:
        return False
    c = state[p, CHECKPOINT] % tb.straight.shape[0]
    state[p, WEAR] = worn_after(tb, state[p, WEAR], tb.turn_angle[c])
    state[p, CHECKPOINT] += 1
    state[p, PREV_LANE] = state[p, LANE]
    state[p, LANE] = lane
    state[p, BIN] = vbin
    state[p, TIME] = arrival
    state[p, LANE_COUNT] = count
    return True
