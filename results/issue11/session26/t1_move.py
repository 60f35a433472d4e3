"""The oracle's first-corner move alone: mcts-lqng's tracker on the oracle's lanes at checkpoints 2-12 of the first
lap (mpc_complex_k3.json) and on the racing line's lanes everywhere else, against fixed-lqng as registered and
against fixed-lqng's tracker on the best fixed line the search found for it (device1/mpc_complex_fixed_alone.json),
from lane 2 of complex."""

from __future__ import annotations

import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from oracle import finish, fixed_on_lanes, load_lanes, oracle_driver, start_race  # noqa: E402


def main() -> None:
    oracle = load_lanes(os.path.join(HERE, "mpc_complex_k3.json"))
    best_fixed = load_lanes(os.path.join(HERE, "device1", "mpc_complex_fixed_alone.json"))
    for last in (9, 10, 12):
        move = {c: lane for c, lane in oracle.items() if c <= last}
        for name, opponent in (("fixed-lqng", "fixed-lqng"), ("best fixed line", fixed_on_lanes(best_fixed))):
            outcome = finish(start_race("complex", oracle_driver(move), (2, 3), opponent=opponent))
            print(json.dumps({"oracle_lanes_to_checkpoint": last, "opponent": name, **outcome}), flush=True)


if __name__ == "__main__":
    main()
