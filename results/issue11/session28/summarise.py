"""The series re-run this session with mcts-lqng as registered (the gated check), per track: races, wins by start
lane, collisions at fault, illegal lane changes, passes, mean finish and wall time (``gated/*_fixed-lqng*.jsonl``).

    python3 results/issue11/session28/summarise.py
"""

import glob
import json
import os
from pathlib import Path

rows: dict[str, dict[int, dict]] = {}
for path in glob.glob("results/issue11/session28/gated/*_fixed-lqng*.jsonl"):
    track = os.path.basename(path).split("_fixed-lqng")[0]
    for line in Path(path).read_text().splitlines():
        row = json.loads(line)
        if "seed" in row:
            rows.setdefault(track, {})[row["seed"]] = row

print(
    "| track | races (seeds) | mcts-lqng wins (lane 2 / lane 3) | collisions at fault per race (mcts / fixed) "
    "| illegal per race (mcts) | passes per race (mcts / fixed) | mean finish (mcts / fixed) [s] | wall per race [s] |"
)
print("|---|---|---|---|---|---|---|---|")
for track in ("complex", "oval", "complex-reversed", "oval-reversed", "kidney"):
    races = list(rows.get(track, {}).values())
    if not races:
        continue
    n = len(races)
    seeds = sorted(r["seed"] for r in races)
    span = f"{seeds[0]}-{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) else "some"
    won = [r for r in races if r["winner"] == 0]
    lane2 = sum(r["lanes"][0] == 2 for r in won)

    def mean(key: str, k: int, races: list[dict] = races) -> float:
        return sum(r[key][k] for r in races) / len(races)

    print(
        f"| `{track}` | {n} ({span}) | **{len(won)}** ({lane2} / {len(won) - lane2}) "
        f"| {mean('faults', 0):.2f} / {mean('faults', 1):.2f} | {mean('illegal', 0):.2f} "
        f"| {mean('passes', 0):.2f} / {mean('passes', 1):.2f} | {mean('time', 0):.2f} / {mean('time', 1):.2f} "
        f"| {sum(r['wall_s'] for r in races) / n:.0f} |"
    )
