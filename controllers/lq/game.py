"""The LQNG tracker's game (paper section 4.2.3) as the matrices :func:`controllers.lq.nash.feedback_nash`
solves: the dynamics linearised at the current state (eq. (24) lqng_dyn) and the quadratic cost terms of
eq. (23) lqng_obj, one function per term (eqs. (20)-(22)).

Every player has a block of ``STATE_SIZE`` state entries, player i's starting at ``STATE_SIZE * i``:
(x, y, v, dtheta), with dtheta the heading change from its current heading, and controls (a, omega). Player
i pays ``1/2 x'Q_i x + q_i'x`` per step; the cost functions add their term into (``Q_i``, ``q_i``) in place
(a handful of entries of a matrix rebuilt 50 times a second: no allocation, and the very summation order of
the tracker that assembles them).

Signs: eq. (23) reads ``min upsilon - (phi - chi)``, which would pull a player towards the others, while the
text says the distance to each opponent "should be maximized". The terms here follow the text: the waypoint
term (20) is paid, the denial term (21) and the separation term (22) are both earned (negative costs).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from sim_core.observation import KartView

STATE_SIZE = 4  # (x, y, v, dtheta) per player
CONTROL_SIZE = 2  # (a, omega) per player
X, Y, SPEED, HEADING = range(STATE_SIZE)  # offsets within a player's block


def linearised_dynamics(players: Sequence[KartView], dt: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """eq. (24) lqng_dyn: ``A`` and every player's ``B_i``, linearised at each player's current heading th0
    and speed v0 (exact in its affine part, as dtheta starts at 0): x' = x + dt (cos th0 v - v0 sin th0
    dtheta), y' = y + dt (sin th0 v + v0 cos th0 dtheta), v' = v + dt a, dtheta' = dtheta + dt omega."""
    n = STATE_SIZE * len(players)
    A = np.eye(n)
    B: list[np.ndarray] = []
    for i, k in enumerate(players):
        s = STATE_SIZE * i
        c, sn = math.cos(k.heading), math.sin(k.heading)
        A[s + X, s + SPEED], A[s + X, s + HEADING] = c * dt, -k.speed * sn * dt
        A[s + Y, s + SPEED], A[s + Y, s + HEADING] = sn * dt, k.speed * c * dt
        Bi = np.zeros((n, CONTROL_SIZE))
        Bi[s + SPEED, 0] = Bi[s + HEADING, 1] = dt
        B.append(Bi)
    return A, B


def add_waypoint_cost(
    Q: np.ndarray,
    q: np.ndarray,
    player: int,
    target: tuple[float, float, float, float],
    w_position: float,
    w_speed: float,
    w_heading: float,
) -> None:
    """eq. (20) lqng_obj1, player ``player``'s own waypoint: ``w_position |p - psi|^2 + w_speed (v - psi_v)^2 +
    w_heading (dtheta - psi_theta)^2`` for ``target`` = (psi_x, psi_y, psi_v, psi_theta)."""
    s = STATE_SIZE * player
    tx, ty, tv, th = target
    for idx, weight, value in (
        (s + X, w_position, tx),
        (s + Y, w_position, ty),
        (s + SPEED, w_speed, tv),
        (s + HEADING, w_heading, th),
    ):
        Q[idx, idx] += 2.0 * weight
        q[idx] -= 2.0 * weight * value


def add_denial_cost(Q: np.ndarray, q: np.ndarray, opponent: int, target: tuple[float, float], weight: float) -> None:
    """eq. (21) lqng_obj2, earned: ``- weight |p_j - psi_j|^2``, the opponent ``opponent`` kept away from its
    predicted waypoint position ``target`` (into the denying player's ``Q``, ``q``)."""
    o = STATE_SIZE * opponent
    for idx, value in ((o + X, target[0]), (o + Y, target[1])):
        Q[idx, idx] -= 2.0 * weight
        q[idx] += 2.0 * weight * value


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
