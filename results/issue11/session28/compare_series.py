"""Race by race: the gated check's races (session28/gated/) against the stored races of the ungated check's five
series (sessions 26-27, seeds 0-49). Prints each race that differs and a count.

    python3 results/issue11/session28/compare_series.py
"""

import glob
import json
import os
from pathlib import Path

STORED = [
    ("complex", "results/issue11/session26/checked_series_complex*.jsonl"),
    ("complex-reversed", "results/issue11/session2[67]/checked_series_complex-reversed*.jsonl"),
    ("oval", "results/issue11/session2[67]/*/checked_series_oval.jsonl"),
    ("oval", "results/issue11/session27/checked_series_oval_10-49.jsonl"),
    ("oval-reversed", "results/issue11/session2[67]/checked_series_oval-reversed*.jsonl"),
    ("kidney", "results/issue11/session26/*/checked_series_kidney.jsonl"),
    ("kidney", "results/issue11/session27/checked_series_kidney_17-49.jsonl"),
]

stored: dict[tuple[str, int], list[list[float]]] = {}
for track, pattern in STORED:
    for path in glob.glob(pattern):
        for line in Path(path).read_text().splitlines():
            row = json.loads(line)
            if "seed" in row and row.get("depth", 3) == 3:
                stored.setdefault((track, row["seed"]), []).append(row["time"])

same = differ = unknown = 0
for path in sorted(glob.glob("results/issue11/session28/gated/*_fixed-lqng*.jsonl")):
    track = os.path.basename(path).split("_fixed-lqng")[0]
    for line in Path(path).read_text().splitlines():
        row = json.loads(line)
        if "seed" not in row:
            continue
        before = stored.get((track, row["seed"]))
        if before is None:
            unknown += 1
            print("no stored race", track, row["seed"])
        elif row["time"] in before:
            same += 1
        else:
            differ += 1
            print("differs", track, row["seed"], row["time"], before)
print(json.dumps({"same": same, "differ": differ, "not_stored": unknown}))
