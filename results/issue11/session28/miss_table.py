"""The gate's evidence: how far each model of the other kart misses it a second on, per opponent (complex, seeds 0
and 1: a lane-2 and a lane-3 start), from the races of ``gate_race.py`` with the gate measuring only
(``trust_miss`` 1e9). Two measurements: the other kart on the lanes the search predicts for it (the rollouts'
model; first version of the gate, ``predicted_lanes_misses_*.jsonl``) and as a racing-line follower (the gate as
shipped, ``follower_misses_*.jsonl``). Also the share of plans at which the shipped rule (median of the last 3
misses at most 0.15 m) trusts the kart.

    python3 results/issue11/session28/miss_table.py
"""

import json
from collections import defaultdict
from pathlib import Path

import numpy as np

D = "results/issue11/session28/"
print(
    "| opponent | model of the other kart | plans | mean [m] | median [m] | 90th pct [m] | "
    + "trusted (median of 3 <= 0.15 m) |"
)
print("|---|---|---|---|---|---|---|")
for model, files in (
    ("on the predicted lanes", ("predicted_lanes_misses_a.jsonl", "predicted_lanes_misses_b.jsonl")),
    ("racing-line follower", ("follower_misses_a.jsonl", "follower_misses_b.jsonl")),
):
    misses: dict[str, list[float]] = defaultdict(list)
    trusted: dict[str, list[bool]] = defaultdict(list)
    for name in files:
        for line in Path(D + name).read_text().splitlines():
            row = json.loads(line)
            m = [x[2] for x in row["misses"]]
            misses[row["opponent"]] += m
            trusted[row["opponent"]] += [float(np.median(m[max(0, i - 2) : i + 1])) <= 0.15 for i in range(len(m))]
    for opponent in ("fixed-lqng", "e2e", "fixed-rl", "mcts-rl"):
        a = np.array(misses[opponent])
        print(
            f"| {opponent} | {model} | {len(a)} | {a.mean():.2f} | {np.median(a):.2f} | {np.percentile(a, 90):.2f} "
            f"| {np.mean(trusted[opponent]):.0%} |"
        )
