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
from sim_core.kernel_arrays import NO_REFCOUNT
from sim_core.rules import lane_change_update

# fields of a player's state
CHECKPOINT = 0  # absolute checkpoint index (not wrapped)
LANE = 1  # 0-based lane
BIN = 2  # velocity bin
TIME = 3  # [0.01 s] time state relative to the root's leader
WEAR = 4  # [1e-4] tyre wear
LANE_COUNT = 5  # eq. (10) gen_lane_var: recent lane changes on this contiguous straight or curve
PREV_LANE = 6  # 0-based lane at the previous checkpoint (to tell when two players' paths cross)
PREV_TIME = 7  # [0.01 s] time state at the previous checkpoint (to check a collision along the section)
MODELLED = 8  # how the player is played: MODEL_FREE (searched) or the lanes of an opponent model (MODEL_LINE, ...)
PACE = 9  # [1e-3] the player's section times over the game's (its measured pace, controllers.tactical.pace); 0: 1
TEAM = 10  # the player's team number from 1; 0: no team (every player for itself)
N_FIELDS = 11
PACE_UNITS = 1000

# values of the MODELLED field (controllers.tactical.opponents chooses one per kart)
MODEL_FREE = 0  # the player searches its own best response (the tactical game's own prediction)
MODEL_LINE = 1  # the racing line's lane at every checkpoint (a line follower)
MODEL_HOLD = 2  # the lane it holds now, at every checkpoint
MODEL_SCRIPT = 3  # MODEL_SCRIPT + s: the lanes of script s of GameTables.scripted_lane (a kart's own recorded lap)

COLLISION_SAMPLES = 5  # points along a section (both ends included) where two karts' positions are compared

NO_PLAYER = -1


@njit(cache=True, inline="always")
def grip(tb: GameTables, wear_units: int) -> float:
    """Lateral acceleration limit [m/s^2] of the kart at tyre wear ``wear_units``."""
    return lateral_limit(tb.kart, min(wear_units / 10_000.0, 1.0))


@njit(cache=True, inline="always")
def corner_speed_at(tb: GameTables, radius: float, a_lat: float) -> float:
    """Cornering speed [m/s] on ``radius`` [m] (0 = straight: top speed) with the lateral limit ``a_lat``
    (:func:`grip`)."""
    if radius <= 0.0:
        return tb.top_speed
    return min(math.sqrt(a_lat * radius), tb.top_speed)


@njit(cache=True, inline="always")
def corner_speed(tb: GameTables, radius: float, wear_units: int) -> float:
    """Cornering speed [m/s] on ``radius`` [m] (0 = straight: top speed) at tyre wear ``wear_units``."""
    return corner_speed_at(tb, radius, grip(tb, wear_units))


@njit(**NO_REFCOUNT)
def worn_after(tb: GameTables, wear_units: int, yaw: float) -> int:
    """Tyre wear [1e-4] after turning through ``yaw`` [rad] more (the kart's exponential wear model)."""
    if yaw <= 0.0:
        return wear_units
    accumulated = yaw_for_wear(tb.kart, min(wear_units / 10_000.0, 0.999999))
    return max(int(tyre_wear(tb.kart, accumulated + yaw) * 10_000.0 + 0.5), wear_units)


@njit(**NO_REFCOUNT)
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


@njit(cache=True, inline="always")
def _too_close(
    tb: GameTables,
    c: int,
    t0: float,
    t1: float,
    l0: float,
    l1: float,
    u0: float,
    u1: float,
    m0: float,
    m1: float,
    window: float,
) -> bool:
    """Whether two karts come within the collision window anywhere along section ``c``.

    One kart goes from lateral offset ``l0`` at time ``t0`` to ``l1`` at ``t1``, the other from ``m0`` at ``u0``
    to ``m1`` at ``u1`` (times in 0.01 s). Both are interpolated linearly along the section; at each sampled
    point the time gap at the same place times the first kart's mean speed is their distance along the track,
    a collision when under ``window`` [m] with the lateral distance under the clearance.

    Two karts already closer than ``window`` at the section's start (a follower that has caught up) collide
    only if they come closer still: the start is given, not chosen, and without this every move of such a
    follower would be illegal (no plan at all for it, while the real kart just keeps its distance).
    """
    speed = tb.distance[c, 0, 0] / max((t1 - t0) / 100.0, 1e-3)
    start_gap = abs(t0 - u0) / 100.0 * speed
    if abs(l0 - m0) < tb.lateral_clearance and start_gap < window:
        window = start_gap
    for k in range(COLLISION_SAMPLES):
        f = k / (COLLISION_SAMPLES - 1)
        gap = abs((t0 + f * (t1 - t0)) - (u0 + f * (u1 - u0))) / 100.0
        lateral = abs((l0 + f * (l1 - l0)) - (m0 + f * (m1 - m0)))
        if lateral < tb.lateral_clearance and gap * speed < window:
            return True
    return False


@njit(cache=True, inline="always")
def _collides(tb: GameTables, state: np.ndarray, p: int, lane: int, arrival: int) -> bool:
    """Whether player ``p`` driving to ``lane`` (arriving at ``arrival``) comes too close to another player.

    Against a player who already drove this section (this round): its actual path. Against one still at the
    checkpoint (behind in time, about to move): that it holds its lane at the same pace, within the shorter
    alongside window, so that nobody moves across a kart alongside (the referee's alongside rule) while a
    leader need not yield to a kart behind it.
    """
    n = tb.straight.shape[0]
    c = state[p, CHECKPOINT] % n
    nxt = (c + 1) % n
    here = state[p, LANE]
    t0 = float(state[p, TIME])
    l0, l1 = tb.lane_offset[c, here], tb.lane_offset[nxt, lane]
    for q in range(state.shape[0]):
        if q == p:
            continue
        if state[q, CHECKPOINT] == state[p, CHECKPOINT] + 1:
            u0, u1 = float(state[q, PREV_TIME]), float(state[q, TIME])
            m0, m1 = tb.lane_offset[c, state[q, PREV_LANE]], tb.lane_offset[nxt, state[q, LANE]]
            window = tb.collision_distance
        elif state[q, CHECKPOINT] == state[p, CHECKPOINT]:
            u0 = float(state[q, TIME])
            u1 = u0 + (arrival - t0)
            m0, m1 = tb.lane_offset[c, state[q, LANE]], tb.lane_offset[nxt, state[q, LANE]]
            window = tb.alongside_distance
        else:
            continue
        if _too_close(tb, c, t0, float(arrival), l0, l1, u0, u1, m0, m1, window):
            return True
    return False


@njit(cache=True, inline="always")
def mover_grip(tb: GameTables, state: np.ndarray, p: int) -> tuple[float, float]:
    """(lateral limit [m/s^2] now, lateral limit at the next checkpoint) of player ``p``: the tyre-wear part of
    :func:`lane_gate`, the same for every lane (the wear model takes a log and an exp), so computed once per
    mover by the callers that try every lane."""
    c = state[p, CHECKPOINT] % tb.straight.shape[0]
    return grip(tb, state[p, WEAR]), grip(tb, worn_after(tb, state[p, WEAR], tb.turn_angle[c]))


@njit(cache=True, inline="always")
def lane_gate(
    tb: GameTables, state: np.ndarray, p: int, lane: int, grip_now: float, grip_next: float
) -> tuple[int, float, float, int]:
    """(new lane-change count, cornering speed [m/s], fastest arrival the next section can brake from [m/s],
    legal flag 0/1) of player ``p`` heading for ``lane``: the part of :func:`move_outcome` that no speed bin
    changes, computed once per lane by the callers that try every bin. ``grip_now``, ``grip_next``: the
    player's :func:`mover_grip`."""
    n = tb.straight.shape[0]
    c = state[p, CHECKPOINT] % n
    here = state[p, LANE]
    # eq. (10) gen_lane_var (the counter) and eq. (11) gen_lane_lim (at most L changes on a straight)
    count, illegal = lane_change_update(
        state[p, LANE_COUNT], here, lane, tb.straight[c], tb.straight[(c + 1) % n], tb.lane_limit
    )
    if illegal:
        return 0, 0.0, 0.0, 0
    v_max = corner_speed_at(tb, tb.corner_radius[c, here, lane], grip_now)
    # no arriving so fast that the next section cannot brake down to its own corner speed (a dead end)
    # (or into a lane from which no lane of the next section is reachable at the lowest speed bin)
    nxt = (c + 1) % n
    bin_width = tb.bin_high[0] - tb.bin_low[0]
    last_bin = tb.bin_low.shape[0] - 1
    # the largest squared entry speed: its root is the largest root (sqrt is correctly rounded, so monotone)
    entry_sq = 0.0
    for j in range(tb.distance.shape[1]):
        _, blocked = lane_change_update(count, lane, j, tb.straight[nxt], tb.straight[(nxt + 1) % n], tb.lane_limit)
        # a corner slower than the lowest bin is still reachable: the lowest bin stands for every speed up to
        # its top (at the wear of the race's last laps the hairpins fall below it, and a game whose every
        # line ends in a dead end there cannot rank anything)
        if blocked:
            continue
        v_next = corner_speed_at(tb, tb.corner_radius[nxt, lane, j], grip_next)
        # the next move arrives at no more than its bin's middle (or the corner speed below it): the fastest
        # arrival here is the one that can still brake down to that over the next section
        v_reach = v_next
        if v_next >= tb.bin_low[0]:
            k = min(int((v_next - tb.bin_low[0]) / bin_width), last_bin)
            v_reach = min(0.5 * (tb.bin_low[k] + tb.bin_high[k]), v_next)
        entry_sq = max(entry_sq, v_reach * v_reach + 2.0 * tb.brake * tb.distance[nxt, lane, j])
    return count, v_max, math.sqrt(entry_sq), 1


@njit(cache=True, inline="always")
def bin_arrival(
    tb: GameTables, state: np.ndarray, p: int, lane: int, vbin: int, v_max: float, entry: float
) -> tuple[int, int]:
    """(arrival time [0.01 s], legal flag 0/1) of player ``p`` choosing ``lane``/``vbin``, given the lane's
    :func:`lane_gate` (``v_max``, ``entry``): the speed-bin half of :func:`move_outcome`."""
    middle = 0.5 * (tb.bin_low[vbin] + tb.bin_high[vbin])
    # the next move starts from the bin's middle speed, whatever the arrival was capped to
    if (vbin > 0 and tb.bin_low[vbin] > v_max) or middle > entry + 1e-9:
        return 0, 0
    c = state[p, CHECKPOINT] % tb.straight.shape[0]
    here = state[p, LANE]
    v0 = 0.5 * (tb.bin_low[state[p, BIN]] + tb.bin_high[state[p, BIN]])
    v1 = min(middle, v_max)
    # entering above the corner speed means braking down to it first; segment_time handles that
    t = segment_time(tb.distance[c, here, lane], v0, v1, tb.accel, tb.brake, v_max)
    if t < 0.0:
        return 0, 0
    # a kart slower or faster than the game's model of the kart takes its sections that much longer or shorter
    pace = 1.0 if state[p, PACE] == 0 else state[p, PACE] / PACE_UNITS
    arrival = state[p, TIME] + int((t * 100.0 + tb.penalty[c, here, lane]) * pace + 0.5)
    # eq. (8) gen_coll_avoid as the paper discretises it: no arrival close in time in the same lane or across a path
    if tb.collision_window > 0:
        target = state[p, CHECKPOINT] + 1
        for q in range(state.shape[0]):
            if q == p or state[q, CHECKPOINT] != target or abs(state[q, TIME] - arrival) >= tb.collision_window:
                continue
            # the same lane, or swapping sides with the other on the way (side by side, the paths cross)
            if state[q, LANE] == lane or (here - state[q, PREV_LANE]) * (lane - state[q, LANE]) < 0:
                return 0, 0
    # the same along the section, with a distance window of a kart length plus a margin
    if tb.collision_distance > 0.0 and _collides(tb, state, p, lane, arrival):
        return 0, 0
    return arrival, 1


@njit(**NO_REFCOUNT)
def move_outcome(tb: GameTables, state: np.ndarray, p: int, lane: int, vbin: int) -> tuple[int, int, int]:
    """(time after the move, new lane-change count, legal flag 0/1) of player ``p`` choosing ``lane``/``vbin``.

    Illegal: over the lane-change limit on a straight, arriving above the cornering speed, boundary
    conditions the 1-D motion cannot meet, arriving faster than the next section can brake from, and (when
    pruning is on) arriving within the collision window of a player who already reached that checkpoint this
    round, in its lane or on its other side (the paths cross).
    """
    grip_now, grip_next = mover_grip(tb, state, p)
    count, v_max, entry, ok = lane_gate(tb, state, p, lane, grip_now, grip_next)
    if not ok:
        return 0, 0, 0
    arrival, ok = bin_arrival(tb, state, p, lane, vbin, v_max, entry)
    if not ok:
        return 0, 0, 0
    return arrival, count, 1


@njit(cache=True, inline="always")
def fastest_in_lane(
    tb: GameTables, state: np.ndarray, p: int, lane: int, grip_now: float, grip_next: float
) -> tuple[int, int, int]:
    """(speed bin, arrival, new lane-change count) of the fastest legal move of player ``p`` into ``lane``
    (bin -1 if there is none). A higher arrival speed never arrives later, so it is the first legal bin from
    the top. ``grip_now``, ``grip_next``: the player's :func:`mover_grip`."""
    count, v_max, entry, gate = lane_gate(tb, state, p, lane, grip_now, grip_next)
    if gate:
        for vbin in range(tb.bin_low.shape[0] - 1, -1, -1):
            arrival, ok = bin_arrival(tb, state, p, lane, vbin, v_max, entry)
            if ok:
                return vbin, arrival, count
    return -1, 0, 0


@njit(cache=True, inline="always")
def model_lane(tb: GameTables, state: np.ndarray, p: int) -> int:
    """The lane player ``p``'s opponent model gives it at its next checkpoint, or -1: it plays freely (not
    modelled, or its model gives no lane there)."""
    model = state[p, MODELLED]
    if model == MODEL_FREE:
        return -1
    checkpoint = (state[p, CHECKPOINT] + 1) % tb.straight.shape[0]
    if model == MODEL_LINE:
        return tb.predicted_lane[checkpoint]
    if model == MODEL_HOLD:
        return state[p, LANE]
    return tb.scripted_lane[model - MODEL_SCRIPT, checkpoint]


@njit(**NO_REFCOUNT)
def allowed_lane(tb: GameTables, state: np.ndarray, p: int) -> int:
    """The only lane a modelled player may take at its next checkpoint (the racing line's lane there), or -1
    when it plays freely (not modelled, no line, or no legal move in that lane: then it avoids like anyone)."""
    lane = model_lane(tb, state, p)
    if lane < 0:
        return -1
    grip_now, grip_next = mover_grip(tb, state, p)
    vbin, _, _ = fastest_in_lane(tb, state, p, lane, grip_now, grip_next)
    return lane if vbin >= 0 else -1


@njit(**NO_REFCOUNT)
def legal_moves(tb: GameTables, state: np.ndarray, p: int, out: np.ndarray) -> int:
    """Write the legal actions (lane * bins + bin) of player ``p`` into ``out``; return how many.

    A modelled player has one move: the earliest arrival in its predicted lane (:func:`allowed_lane`)."""
    bins = tb.bin_low.shape[0]
    lanes = tb.distance.shape[1]
    grip_now, grip_next = mover_grip(tb, state, p)
    if state[p, MODELLED] != 0:
        # the model's line follower drives as fast as it legally can in its lane: one move
        only = model_lane(tb, state, p)
        if only >= 0:
            vbin, _, _ = fastest_in_lane(tb, state, p, only, grip_now, grip_next)
            if vbin >= 0:
                out[0] = only * bins + vbin
                return 1
            # no legal move in the line's lane: the earliest arrival in any other lane
        best, best_arrival = -1, 1 << 60
        for lane in range(lanes):
            if lane == only:
                continue
            vbin, arrival, _ = fastest_in_lane(tb, state, p, lane, grip_now, grip_next)
            if vbin >= 0 and arrival < best_arrival:
                best, best_arrival = lane * bins + vbin, arrival
        if best < 0:
            return 0
        out[0] = best
        return 1
    k = 0
    for lane in range(lanes):
        _, v_max, entry, gate = lane_gate(tb, state, p, lane, grip_now, grip_next)
        if not gate:
            continue
        for vbin in range(bins):
            _, ok = bin_arrival(tb, state, p, lane, vbin, v_max, entry)
            if ok:
                out[k] = lane * bins + vbin
                k += 1
    return k


@njit(**NO_REFCOUNT)
def apply_move(tb: GameTables, state: np.ndarray, p: int, action: int) -> bool:
    """Play ``action`` for player ``p`` in place; False (state unchanged) if it is illegal."""
    bins = tb.bin_low.shape[0]
    lane, vbin = action // bins, action % bins
    arrival, count, ok = move_outcome(tb, state, p, lane, vbin)
    if not ok:
        return False
    apply_outcome(tb, state, p, lane, vbin, arrival, count)
    return True


@njit(**NO_REFCOUNT)
def apply_outcome(tb: GameTables, state: np.ndarray, p: int, lane: int, vbin: int, arrival: int, count: int) -> None:
    """Play the legal move ``lane``/``vbin`` of player ``p`` whose :func:`move_outcome` (``arrival``,
    ``count``) the caller already has, in place."""
    c = state[p, CHECKPOINT] % tb.straight.shape[0]
    state[p, WEAR] = worn_after(tb, state[p, WEAR], tb.turn_angle[c])
    state[p, CHECKPOINT] += 1
    state[p, PREV_LANE] = state[p, LANE]
    state[p, PREV_TIME] = state[p, TIME]
    state[p, LANE] = lane
    state[p, BIN] = vbin
    state[p, TIME] = arrival
    state[p, LANE_COUNT] = count
