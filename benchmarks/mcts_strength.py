"""Search strength against iterations: how often MCTS's first move is an exactly optimal one.

200 random 2-player states on `oval` and `complex` (velocity bins 2 m/s, horizon 2) are solved exactly by
backward induction (controllers/tactical/exact.py); MCTS with the planner's defaults then searches each with a
growing iteration budget. Run from the repo root: ``.venv/bin/python benchmarks/mcts_strength.py`` (``--help``: the
number of states and the budgets); the last line is one JSON object mapping iterations to the fraction of exactly
optimal first moves.
"""

from __future__ import annotations

import argparse
import json

from controllers.tactical.exact import optimal_first_moves, random_small_games
from controllers.tactical.mcts import SearchTree
from controllers.tactical.planner import DEFAULT_EXPLORATION, DEFAULT_GREEDY

BUDGETS = (50, 200, 1000, 3000, 10000, 20000)


def main() -> None:
    """Solve the states exactly, then search each at every budget; print a line per budget, then the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--games", type=int, default=200, help="random states solved")
    parser.add_argument(
        "--budgets",
        type=lambda s: tuple(int(x) for x in s.split(",")),
        default=BUDGETS,
        help="iterations, comma separated",
    )
    args = parser.parse_args()
    games = random_small_games(args.games)
    optimal = [optimal_first_moves(tb, state, horizon=2)[1] for tb, state in games]
    curve = {}
    for budget in args.budgets:
        hits = 0
        for (tb, state), best in zip(games, optimal):
            tree = SearchTree(budget + 1, 2, 64)
            tree.run(tb, state, 2, budget, 1, DEFAULT_EXPLORATION, DEFAULT_GREEDY)
            pick = max(tree.children(0), key=lambda c: int(tree.visits[c]))
            hits += int(tree.action[pick]) in best
        curve[budget] = hits / len(games)
        print(f"{budget:>6} iterations: exactly optimal first move in {hits}/{len(games)} states")
    print(json.dumps({"optimal_first_move_fraction_by_iterations": curve}))


if __name__ == "__main__":
    main()
