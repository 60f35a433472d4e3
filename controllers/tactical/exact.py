"""Exhaustive solution of small discrete games by backward induction: the reference that the MCTS search is
measured against (``tests/controllers/test_tactical_planner.py``, ``benchmarks/mcts_strength.py``).

Every mover picks the move that maximises its own :func:`~controllers.tactical.value.terminal_values` value
given everyone's later best responses (a subgame-perfect equilibrium). The cost grows as the number of legal
moves to the power of players times horizon: two players and a horizon of two or three checkpoints at most.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from controllers.tactical import rules
from controllers.tactical.game import GameParams, GameTables, build_tables
from controllers.tactical.mcts import reference_times
from controllers.tactical.value import terminal_values
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track


@njit(cache=True)
def exact_values(
    tb: GameTables, state: np.ndarray, round_cp: int, final_round: int, reference: np.ndarray, out: np.ndarray
) -> None:
    """Subgame-perfect values of ``state``: every mover picks the move that maximises its own value."""
    players = state.shape[0]
    while round_cp < final_round and rules.next_player(state, round_cp) == rules.NO_PLAYER:
        round_cp += 1
    if round_cp >= final_round:
        terminal_values(tb, state, reference, out)
        return
    p = rules.next_player(state, round_cp)
    moves = np.empty(tb.distance.shape[1] * tb.bin_low.shape[0], dtype=np.int64)
    count = rules.legal_moves(tb, state, p, moves)
    if count == 0:
        for q in range(players):
            out[q] = 1.0
        out[p] = 0.0
        return
    best = -1.0
    child_values = np.empty(players)
    for i in range(count):
        child = state.copy()
        rules.apply_move(tb, child, p, moves[i])
        exact_values(tb, child, round_cp, final_round, reference, child_values)
        if child_values[p] > best:
            best = child_values[p]
            out[:] = child_values


def optimal_first_moves(
    tb: GameTables, state: np.ndarray, horizon: int, tolerance: float = 1e-9
) -> tuple[int, set[int], np.ndarray]:
    """(mover, set of optimal first actions, value of each legal first action for the mover)."""
    round_cp = int(state[:, rules.CHECKPOINT].min())
    p = rules.next_player(state, round_cp)
    moves = np.empty(tb.distance.shape[1] * tb.bin_low.shape[0], dtype=np.int64)
    count = rules.legal_moves(tb, state, p, moves)
    values = np.empty(count)
    out = np.empty(state.shape[0])
    reference = reference_times(tb, state, horizon)
    for i in range(count):
        child = state.copy()
        rules.apply_move(tb, child, p, moves[i])
        exact_values(tb, child, round_cp, round_cp + horizon, reference, out)
        values[i] = out[p]
    best = values.max()
    return p, {int(moves[i]) for i in range(count) if values[i] >= best - tolerance}, values


def random_small_games(count: int, seed: int = 0) -> list[tuple[GameTables, np.ndarray]]:
    """``count`` random 2-player root states on ``oval`` and ``complex`` (alternately; velocity bins 2 m/s),
    each with at least two legal first moves: small enough to solve exactly with :func:`optimal_first_moves`."""
    rng = np.random.default_rng(seed)
    tables = [build_tables(get_track(n), PAPER_KART, GameParams(velocity_bin_width=2.0)) for n in ("oval", "complex")]
    games: list[tuple[GameTables, np.ndarray]] = []
    moves = np.empty(64, dtype=np.int64)
    while len(games) < count:
        tb = tables[len(games) % 2]
        state = np.zeros((2, rules.N_FIELDS), dtype=np.int64)
        state[:, rules.CHECKPOINT] = rng.integers(0, len(tb.straight))
        state[:, rules.LANE] = rng.choice(4, 2, replace=False)
        state[:, rules.BIN] = rng.integers(0, len(tb.bin_low), 2)
        state[:, rules.TIME] = (0, rng.integers(0, 60))
        state[:, rules.WEAR] = rng.integers(1000, 5000, 2)
        state[:, rules.LANE_COUNT] = rng.integers(0, 3, 2)
        mover = rules.next_player(state, int(state[0, rules.CHECKPOINT]))
        if rules.legal_moves(tb, state, mover, moves) >= 2:
            games.append((tb, state))
    return games
