"""The MCTS value function: what a finished discrete game is worth to each player (paper eq. (1) gen_obj,
``min gamma^i - gamma^j``: arrive before the others with the largest time advantage).

Values lie in [0, 1] (0.5 = level) so that the UCT exploration constant of :mod:`controllers.tactical.mcts`
has one scale for every track; the search, its rollouts and the exact reference
(:mod:`controllers.tactical.exact`) all score finished games with :func:`terminal_values`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from controllers.tactical.game import GameTables
from controllers.tactical.rules import TEAM, TIME
from sim_core.kernel_arrays import NO_REFCOUNT

RACE_SHARE = 0.8  # share of the value range given to the time advantage over the others (the rest: own pace)


@njit(**NO_REFCOUNT)
def terminal_values(tb: GameTables, state: np.ndarray, reference: np.ndarray, out: np.ndarray) -> None:
    """Value in [0, 1] of a finished game for every player.

    Mostly (``RACE_SHARE``) the time advantage over the mean of the others, in units of ``value_scale`` and
    clipped (eq. (1) gen_obj); the rest rewards the player's own pace against ``reference[p]``
    (its time under the fast-move rollout policy from the root), so a player far ahead or alone still
    prefers the faster plan instead of seeing every move as equal.

    A player with team-mates in the game (the same ``TEAM`` number, not 0) plays for its team: the time advantage
    is the opponents' mean arrival over its team's (itself included), so a place its team-mate gains is worth
    what its own is, and holding an opponent up is worth it too; with no opponent in the game it is 0 (the
    original's team objective was NaN there). Without team-mates the value is eq. (1) as above.
    """
    n = state.shape[0]
    total = 0
    for q in range(n):
        total += state[q, TIME]
    for p in range(n):
        pace = min(max((reference[p] - state[p, TIME]) / tb.value_scale, -1.0), 1.0)
        if n == 1:
            out[p] = 0.5 + 0.5 * pace
            continue
        team_time, team_size = _team(state, p)
        if team_size == 1:
            others = (total - state[p, TIME]) / (n - 1)
            # eq. (1) gen_obj: the time advantage gamma^j - gamma^i over the others' mean arrival
            race = min(max((others - state[p, TIME]) / tb.value_scale, -1.0), 1.0)
        elif team_size == n:
            race = 0.0  # team-mates alone: no place to gain or lose
        else:
            # eq. (1) gen_obj for the team: the opponents' mean arrival over the team's
            opponents = (total - team_time) / (n - team_size)
            race = min(max((opponents - team_time / team_size) / tb.value_scale, -1.0), 1.0)
        out[p] = 0.5 + 0.5 * (RACE_SHARE * race + (1.0 - RACE_SHARE) * pace)


@njit(**NO_REFCOUNT)
def _team(state: np.ndarray, p: int) -> tuple[int, int]:
    """The summed time states of player ``p``'s team in the game (itself included) and how many they are (1: no
    team-mate, or no team)."""
    if state[p, TEAM] == 0:
        return state[p, TIME], 1
    time, size = 0, 0
    for q in range(state.shape[0]):
        if state[q, TEAM] == state[p, TEAM]:
            time += state[q, TIME]
            size += 1
    return time, size
