"""The LQNG tracker's game (paper section 4.2.3) as the matrices :func:`controllers.lq.nash.feedback_nash`
solves: the dynamics linearised at the current state (eq. (24) lqng_dyn) and the quadratic cost terms of
eq. (23) lqng_obj, one function per term (eqs. (20)-(22)).

Every player has a block of ``STATE_SIZE`` state entries, player i's starting at ``STATE_SIZE * i``:
(x, y, v, dtheta), with dtheta the heading change from its current heading, and controls (a, omega). Player
i pays ``1/2 x'Q_i x + q_i'x`` per step; the cost functions add their term into (``Q_i``, ``q_i``) in place
(a handful of entries of a matrix rebuilt 50 times a second: no allocation, and the very summation order of
the tracker that assembles them). :func:`solve_tracker_game` assembles the whole game and solves it in one compiled
call: the tracker solves one at every step of every race and of every rollout of a checked plan, and assembling it
in Python cost more than solving it.

Signs: eq. (23) reads ``min upsilon - (phi - chi)``, which would pull a player towards the others, while the
text says the distance to each opponent "should be maximized". The terms here follow the text: the waypoint
term (20) is paid, the denial term (21) and the separation term (22) are both earned (negative costs).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from controllers.lq.nash import coupled_riccati

STATE_SIZE = 4  # (x, y, v, dtheta) per player
CONTROL_SIZE = 2  # (a, omega) per player
X, Y, SPEED, HEADING = range(STATE_SIZE)  # offsets within a player's block


@njit(cache=True)
def linearised_dynamics(headings: np.ndarray, speeds: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """eq. (24) lqng_dyn: ``A`` and every player's ``B_i`` side by side (``B_all``, player i's two columns
    from ``2 i``), linearised at each player's current heading th0 and speed v0 (exact in its affine part, as
    dtheta starts at 0): x' = x + dt (cos th0 v - v0 sin th0 dtheta), y' = y + dt (sin th0 v + v0 cos th0
    dtheta), v' = v + dt a, dtheta' = dtheta + dt omega."""
    players = headings.shape[0]
    n = STATE_SIZE * players
    A = np.eye(n)
    B_all = np.zeros((n, CONTROL_SIZE * players))
    for i in range(players):
        s = STATE_SIZE * i
        c, sn = math.cos(headings[i]), math.sin(headings[i])
        A[s + X, s + SPEED] = c * dt
        A[s + X, s + HEADING] = -speeds[i] * sn * dt
        A[s + Y, s + SPEED] = sn * dt
        A[s + Y, s + HEADING] = speeds[i] * c * dt
        B_all[s + SPEED, CONTROL_SIZE * i] = dt
        B_all[s + HEADING, CONTROL_SIZE * i + 1] = dt
    return A, B_all


@njit(cache=True)
def add_waypoint_cost(
    Q: np.ndarray,
    q: np.ndarray,
    player: int,
    target: np.ndarray,
    w_position: float,
    w_speed: float,
    w_heading: float,
) -> None:
    """eq. (20) lqng_obj1, player ``player``'s own waypoint: ``w_position |p - psi|^2 + w_speed (v - psi_v)^2 +
    w_heading (dtheta - psi_theta)^2`` for ``target`` = (psi_x, psi_y, psi_v, psi_theta)."""
    s = STATE_SIZE * player
    weights = (w_position, w_position, w_speed, w_heading)
    for axis in range(STATE_SIZE):
        idx = s + axis
        Q[idx, idx] += 2.0 * weights[axis]
        q[idx] -= 2.0 * weights[axis] * target[axis]


@njit(cache=True)
def add_denial_cost(Q: np.ndarray, q: np.ndarray, opponent: int, target: np.ndarray, weight: float) -> None:
    """eq. (21) lqng_obj2, earned: ``- weight |p_j - psi_j|^2``, the opponent ``opponent`` kept away from its
    predicted waypoint position ``target`` (its first two entries; into the denying player's ``Q``, ``q``)."""
    o = STATE_SIZE * opponent
    for axis in (X, Y):
        Q[o + axis, o + axis] -= 2.0 * weight
        q[o + axis] += 2.0 * weight * target[axis]


@njit(cache=True)
def add_separation_cost(Q: np.ndarray, player: int, other: int, weight: float) -> None:
    """eq. (22) lqng_obj3, earned (see the module note on signs): ``- weight |p_i - p_j|^2`` between players
    ``player`` and ``other`` (into player i's ``Q``)."""
    s, o = STATE_SIZE * player, STATE_SIZE * other
    for axis in (X, Y):
        a, b = s + axis, o + axis
        Q[a, a] -= 2.0 * weight
        Q[b, b] -= 2.0 * weight
        Q[a, b] += 2.0 * weight
        Q[b, a] += 2.0 * weight


@njit(cache=True)
def solve_tracker_game(
    headings: np.ndarray,
    speeds: np.ndarray,
    targets: np.ndarray,
    position_weights: np.ndarray,
    speed_weight: float,
    heading_weight: float,
    separation: np.ndarray,
    denied: np.ndarray,
    deny_weight: float,
    control_weight: float,
    dt: float,
    horizon: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The tracker's game, eq. (23) lqng_obj under eq. (24) lqng_dyn, solved: the feedback Nash gains ``P``
    (T, 2 players, 4 players) and ``alpha`` (T, 2 players) of :func:`controllers.lq.nash.feedback_nash`.

    Player i (0: the ego) pays its waypoint term (20) toward ``targets[i]`` (psi_x, psi_y, psi_v, psi_theta)
    with ``position_weights[i]``, ``speed_weight`` and ``heading_weight``, earns the separation term (22) from
    each other player j weighted ``separation[i, j]`` and, the ego alone, the denial term (21) of each opponent
    j with ``denied[j]`` (weighted ``deny_weight``); every player's controls cost ``control_weight`` |u|^2 / 2."""
    players = headings.shape[0]
    n = STATE_SIZE * players
    A, B_all = linearised_dynamics(headings, speeds, dt)
    Q = np.zeros((players, n, n))
    q = np.zeros((players, n))
    for i in range(players):
        add_waypoint_cost(Q[i], q[i], i, targets[i], position_weights[i], speed_weight, heading_weight)
        for j in range(players):
            if j == i:
                continue
            add_separation_cost(Q[i], i, j, separation[i, j])
            if i == 0 and denied[j]:
                add_denial_cost(Q[i], q[i], j, targets[j], deny_weight)
    total = CONTROL_SIZE * players
    R_all = np.zeros((total, total))
    offsets = np.zeros(players + 1, dtype=np.int64)
    for i in range(players):
        for axis in range(CONTROL_SIZE):
            R_all[CONTROL_SIZE * i + axis, CONTROL_SIZE * i + axis] = control_weight
        offsets[i + 1] = CONTROL_SIZE * (i + 1)
    return coupled_riccati(A, B_all, offsets, Q, q, R_all, np.zeros(n), horizon)
