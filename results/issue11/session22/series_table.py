"""The issue's table from the JSON summaries (last lines) of series files: per track, each kart's wins · mean finish ·
collisions at fault per race · illegal lane changes per race (per step) · safety score · passes per race · Δr · Δv,
then mcts-lqng's prediction accuracy and fewest plan waypoints. argv: the series files.

    .venv/bin/python results/issue11/session22/series_table.py results/issue11/session22/h2h_*.txt
"""

import json
import sys
from pathlib import Path

print("| track | mcts-lqng | fixed-lqng | prediction | fewest waypoints |")
print("|---|---|---|---|---|")
for path in sys.argv[1:]:
    summary = json.loads(Path(path).read_text().strip().splitlines()[-1])
    cells = []
    for kart in ("mcts-lqng", "fixed-lqng"):
        k = summary[kart]
        cells.append(
            f"{summary['wins'][kart]} · {k['time']:.2f} s · {k['faults']:.2f} · {k['illegal_per_step']:.2f} · "
            f"{k['safety']:.2f} · {k['passes']:.2f} · {k['delta_r']:.3f} · {k['delta_v']:.3f}"
        )
    tactical = summary["mcts-lqng"]
    print(
        f"| `{summary['track'].split('/')[-1]}` | {cells[0]} | {cells[1]} | {tactical['prediction_accuracy']:.3f} | "
        f"{tactical['fewest_plan_waypoints']} |"
    )
