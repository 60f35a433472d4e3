"""Feedback LQ Nash solve time: the tracker-sized game (4 states and 2 controls per player, horizon 4).

Median over many solves with the tracker's real cost structure for 2 and 4 players. Run from the repo
root: ``.venv/bin/python benchmarks/lqng.py`` (``--repeats N``: solves timed per size); the last line is one JSON
object (`solve_ms_2p`, `solve_ms_4p`).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

from controllers.lq.nash import feedback_nash

REPEATS = 3000


def tracker_game(
    players: int, rng: np.random.Generator
) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    n = 4 * players
    dt = 0.02
    A = np.eye(n)
    B = []
    for p in range(players):
        v, th = rng.uniform(5, 15), rng.uniform(-np.pi, np.pi)
        s = 4 * p
        A[s, s + 2], A[s, s + 3] = np.cos(th) * dt, -v * np.sin(th) * dt
        A[s + 1, s + 2], A[s + 1, s + 3] = np.sin(th) * dt, v * np.cos(th) * dt
        Bp = np.zeros((n, 2))
        Bp[s + 2, 0] = Bp[s + 3, 1] = dt
        B.append(Bp)
    Q = [np.diag(rng.uniform(0.01, 1.0, n)) for _ in range(players)]
    q = [rng.normal(size=n) for _ in range(players)]
    R = [0.115 * np.eye(2) for _ in range(players)]
    return A, B, Q, q, R


def median_ms(players: int, repeats: int = REPEATS) -> float:
    """Median milliseconds of one solve of a ``players``-player game, over ``repeats`` solves."""
    rng = np.random.default_rng(players)
    game = tracker_game(players, rng)
    feedback_nash(*game, horizon=4)  # compile
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        feedback_nash(*game, horizon=4)
        times.append((time.perf_counter() - t0) * 1000)
    return statistics.median(times)


def main() -> None:
    """Time both game sizes; print a line, then the JSON summary."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=REPEATS, help="solves timed per game size")
    repeats = parser.parse_args().repeats
    two, four = median_ms(2, repeats), median_ms(4, repeats)
    print(f"2 players: {two:.4f} ms; 4 players: {four:.4f} ms (median of {repeats}, horizon 4)")
    print(json.dumps({"solve_ms_2p": round(two, 4), "solve_ms_4p": round(four, 4), "target_solve_ms_2p": 0.2}))


if __name__ == "__main__":
    main()
