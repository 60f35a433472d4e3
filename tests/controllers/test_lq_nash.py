"""The feedback Nash solver against independent computations: scipy's LQR for one player, and each
player's best response to the others' fixed feedback (a single-agent Riccati recursion written separately)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as hs

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
