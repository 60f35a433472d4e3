"""The feedback Nash solver against independent computations: scipy's LQR for one player, and each
player's best response to the others' fixed feedback (a single-agent Riccati recursion written separately)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as hs

from controllers.lq.game import (
    add_denial_cost,
    add_separation_cost,
    add_waypoint_cost,
    linearised_dynamics,
    solve_tracker_game,
)
from controllers.lq.nash import feedback_nash


def random_game(rng: np.random.Generator, n: int, sizes: list[int]):
    A = np.eye(n) + 0.1 * rng.normal(size=(n, n))
    B = [rng.normal(size=(n, m)) for m in sizes]
    Q, q, R = [], [], []
    for m in sizes:
        M = rng.normal(size=(n, n))
        Q.append(M @ M.T + 0.1 * np.eye(n))
        q.append(rng.normal(size=n))
        N = rng.normal(size=(m, m))
        R.append(N @ N.T + np.eye(m))
    c = 0.1 * rng.normal(size=n)
    return A, B, Q, q, R, c


def test_one_player_equals_the_discrete_lqr() -> None:
    rng = np.random.default_rng(0)
    A, B, Q, _, R, _ = random_game(rng, 4, [2])
    P, alpha = feedback_nash(A, B, Q, [np.zeros(4)], R, horizon=400)
    X = scipy.linalg.solve_discrete_are(A, B[0], Q[0], R[0])
    K = np.linalg.solve(R[0] + B[0].T @ X @ B[0], B[0].T @ X @ A)
    assert np.allclose(P[0], K, atol=1e-8)
    assert np.allclose(alpha[0], 0.0, atol=1e-12)


def best_response(A, B_i, Q_i, q_i, R_i, c, others_gain, others_alpha, B_others):
    """Player i's optimal affine feedback against fixed strategies, by dynamic programming on [x; 1]."""
    T = others_gain.shape[0]
    n = A.shape[0]
    # homogeneous form: z = [x; 1], z' = Ah z + Bh u with the others' feedback folded into Ah
    Qh = np.zeros((n + 1, n + 1))
    Qh[:n, :n] = Q_i
    Qh[:n, n] = Qh[n, :n] = q_i
    V = Qh.copy()
    gains = np.zeros((T, B_i.shape[1], n + 1))
    for t in range(T - 1, -1, -1):
        Ah = np.eye(n + 1)
        Ah[:n, :n] = A - B_others @ others_gain[t]
        Ah[:n, n] = c - B_others @ others_alpha[t]
        Bh = np.vstack([B_i, np.zeros((1, B_i.shape[1]))])
        H = R_i + Bh.T @ V @ Bh
        K = np.linalg.solve(H, Bh.T @ V @ Ah)
        gains[t] = K
        Acl = Ah - Bh @ K
        V = Qh + K.T @ R_i @ K + Acl.T @ V @ Acl
    return gains[:, :, :n], gains[:, :, n]


@settings(max_examples=25)
@given(seed=hs.integers(0, 2**31 - 1), players=hs.integers(2, 4), horizon=hs.integers(1, 8))
def test_each_player_best_responds_to_the_others(seed: int, players: int, horizon: int) -> None:
    rng = np.random.default_rng(seed)
    n = 3 + players
    sizes = [int(rng.integers(1, 3)) for _ in range(players)]
    A, B, Q, q, R, c = random_game(rng, n, sizes)
    P, alpha = feedback_nash(A, B, Q, q, R, horizon, c)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    for i in range(players):
        mine = slice(offsets[i], offsets[i + 1])
        others = [j for j in range(players) if j != i]
        rows = np.concatenate([np.arange(offsets[j], offsets[j + 1]) for j in others])
        B_others = np.hstack([B[j] for j in others])
        K, k = best_response(A, B[i], Q[i], q[i], R[i], c, P[:, rows, :], alpha[:, rows], B_others)
        assert np.allclose(P[:, mine, :], K, atol=1e-8, rtol=1e-8)
        assert np.allclose(alpha[:, mine], k, atol=1e-8, rtol=1e-8)


def test_gains_are_finite_for_the_tracker_sized_game() -> None:
    rng = np.random.default_rng(1)
    A, B, Q, q, R, c = random_game(rng, 8, [2, 2])
    P, alpha = feedback_nash(A, B, Q, q, R, 4, c)
    assert P.shape == (4, 4, 8) and alpha.shape == (4, 4)
    assert np.isfinite(P).all() and np.isfinite(alpha).all()
    with pytest.raises(np.linalg.LinAlgError):
        feedback_nash(np.eye(2), [np.zeros((2, 1))], [np.zeros((2, 2))], [np.zeros(2)], [np.zeros((1, 1))], 1)


def test_the_trackers_compiled_game_is_the_game_assembled_term_by_term() -> None:
    """solve_tracker_game (assembled and solved in one compiled call) against the same three-player game built
    from eq. (24) and the cost terms (20)-(22) one call at a time and solved by feedback_nash."""
    rng = np.random.default_rng(7)
    players, dt, horizon = 3, 0.02, 4
    headings, speeds = rng.uniform(-3, 3, players), rng.uniform(0, 15, players)
    targets = rng.normal(size=(players, 4))
    position_weights = rng.uniform(0.05, 1.0, players)
    separation = rng.uniform(0.01, 0.2, (players, players))
    denied = np.array([False, True, False])
    P, alpha = solve_tracker_game(
        headings, speeds, targets, position_weights, 1.0, 3.5, separation, denied, 0.02, 0.115, dt, horizon
    )
    A, B_all = linearised_dynamics(headings, speeds, dt)
    n = 4 * players
    Q, q = [np.zeros((n, n)) for _ in range(players)], [np.zeros(n) for _ in range(players)]
    for i in range(players):
        add_waypoint_cost(Q[i], q[i], i, targets[i], position_weights[i], 1.0, 3.5)
        for j in range(players):
            if j != i:
                add_separation_cost(Q[i], i, j, separation[i, j])
                if i == 0 and denied[j]:
                    add_denial_cost(Q[i], q[i], j, targets[j], 0.02)
    B = [B_all[:, 2 * i : 2 * i + 2] for i in range(players)]
    assert np.allclose(B_all[4 * 1 + 2], [0, 0, dt, 0, 0, 0])  # player 1's speed moves with its own a alone
    P_ref, alpha_ref = feedback_nash(A, B, Q, q, [0.115 * np.eye(2)] * players, horizon)
    np.testing.assert_allclose(P, P_ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(alpha, alpha_ref, rtol=1e-12, atol=1e-12)
    # the denial makes the ego pay to pull opponent 1 off its waypoint: q of the ego at that opponent's x is set
    assert q[0][4] == 2.0 * 0.02 * targets[1][0]
