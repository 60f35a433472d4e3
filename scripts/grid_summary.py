"""Summarise a tournament's stats JSON (``karting tournament stats --json``) for docs/results/README.md: the
combined win matrix with each agent's wins / races, and the safety means (std. dev.) per race.

    .venv/bin/python scripts/grid_summary.py docs/results/paper_grid.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

AGENTS = ("mcts-rl", "e2e", "fixed-rl", "mcts-lqng", "fixed-lqng")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("stats", type=Path)
    parser.add_argument("--track", default="combined")
    args = parser.parse_args()
    table = json.loads(args.stats.read_text())["tracks"][args.track]
    wins, safety = table["wins"], table["safety"]
    print("| agent | " + " | ".join(f"vs {a}" for a in AGENTS) + " | wins / races |")
    print("|---" * (len(AGENTS) + 2) + "|")
    for a in AGENTS:
        cells = ["-" if a == b else str(wins.get(a, {}).get(b, 0)) for b in AGENTS]
        total = sum(wins.get(a, {}).values())
        races = safety[a]["races"]
        print(f"| {a} | " + " | ".join(cells) + f" | {total} / {races} ({100 * total / races:.0f}%) |")
    print()
    print("| agent | collisions at fault | illegal lane changes | safety score | finished / races |")
    print("|---|---|---|---|---|")
    for a in AGENTS:
        s = safety[a]

        def cell(key: str, figures: dict = s) -> str:
            return f"{figures[key]['mean']:.3g} ({figures[key]['std']:.3g})"

        print(
            f"| {a} | {cell('collisions_at_fault')} | {cell('illegal_lane_changes')} | {cell('safety_score')} "
            f"| {s['finished']} / {s['races']} |"
        )


if __name__ == "__main__":
    main()
