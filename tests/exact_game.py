"""Exhaustive solution of small discrete games (backward induction), the reference for the MCTS tests."""

from __future__ import annotations

import numpy as np
from numba import njit

from controllers.tactical import discrete as dg
from controllers.tactical.mcts import reference_times


@njit(cache=True)
def exact_values(
    tb, state: np.ndarray, round_cp: int, final_round: int, reference: np.ndarray, out: np.ndarray
) -> None:
    """Subgame-perfect values of ``state``: every mover picks the move that maximises its own value."""
    players = state.shape[0]
    while round_cp < final_round and dg.next_player(state, round_cp) == dg.NO_PLAYER:
        round_cp += 1
    if round_cp >= final_round:
        dg.terminal_values(tb, state, reference, out)
        return
    p = dg.next_player(state, round_cp)
    moves = np.empty(tb.distance.shape[1] * tb.bin_low.shape[0], dtype=np.int64)
    count = dg.legal_moves(tb, state, p, moves)
    if count == 0:
        for q in range(players):
            out[q] = 1.0
        out[p] = 0.0
        return
    best = -1.0
    child_values = np.empty(players)
    for i in range(count):
        child = state.copy()
        dg.apply_move(tb, child, p, moves[i])
        exact_values(tb, child, round_cp, final_round, reference, child_values)
        if child_values[p] > best:
            best = child_values[p]
            out[:] = child_values


def optimal_first_moves(
    tb, state: np.ndarray, horizon: int, tolerance: float = 1e-9
) -> tuple[int, set[int], np.ndarray]:
    """(mover, set of optimal first actions, value of each legal first action for the mover)."""
    round_cp = int(state[:, dg.CHECKPOINT].min())
    p = dg.next_player(state, round_cp)
    moves = np.empty(tb.distance.shape[1] * tb.bin_low.shape[0], dtype=np.int64)
    count = dg.legal_moves(tb, state, p, moves)
    values = np.empty(count)
    out = np.empty(state.shape[0])
    reference = reference_times(tb, state, horizon)
    for i in range(count):
        child = state.copy()
        dg.apply_move(tb, child, p, moves[i])
        exact_values(tb, child, round_cp, round_cp + horizon, reference, out)
        values[i] = out[p]
    best = values.max()
    return p, {int(moves[i]) for i in range(count) if values[i] >= best - tolerance}, values
