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
from controllers.tactical.rules import TIME
from sim_core.kernel_arrays import NO_REFCOUNT

RACE_SHARE = 0.8  # share of the value range given to the time advantage over the others (the rest: own pace)


@njit(**NO_REFCOUNT)
def terminal_values(tb: GameTables, state: np.ndarray, reference: np.ndarray, out: np.ndarray) -> None:
    """Value in [0, 1] of a finished game for every player.

    Mostly (``RACE_SHARE``) the time advantage over the mean of the others, in units of ``value_scale`` and
    clipped (eq. (1) gen_obj); the rest rewards the player's own pace against ``reference[p]``
    (its time under the fast-move rollout policy from the root), so a player far ahead or alone still
    prefers the faster plan instead of seeing every move as equal.
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
        others = (total - state[p, TIME]) / (n - 1)
        # eq. (1) gen_obj: the time advantage gamma^j - gamma^i over the others' mean arrival
        race = min(max((others - state[p, TIME]) / tb.value_scale, -1.0), 1.0)
        out[p] = 0.5 + 0.5 * (RACE_SHARE * race + (1.0 - RACE_SHARE) * pace)
