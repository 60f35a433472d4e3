"""Phase 2 of ``random_search.py`` alone: the ``finalists`` closest clean settings of a finished phase 1 (and the
registered setting), raced from lane 3 and on the other tracks. Run from the repo root (the kidney track's path is
relative to it).

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session25/validate.py \\
        results/issue11/session25/local/nopace_search.jsonl --finalists 8 --out validate.jsonl
"""

from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import typer

sys.path.insert(0, str(Path(__file__).parent))
import random_search


def main(results: Path, finalists: int = 8, workers: int = 2, out: Path = Path("validate.jsonl")) -> None:
    """Every validation race of the chosen settings, one JSON line each."""
    rows = [json.loads(line) for line in results.open()]
    first = {r["config"]: r for r in reversed(rows) if r["track"] == "complex" and r["lane"] == 2}
    clean = sorted(
        (r for r in first.values() if r["margin"] is not None and r["faults"][0] == 0 and r["config"]),
        key=lambda r: r["margin"],
    )
    chosen = [first[0], *clean[:finalists]]
    jobs = [
        (r["config"], r["setting"], track, lane, 1 if lane == 3 else 4, r.get("opponent") or None)
        for r in chosen
        for track, lane in random_search.VALIDATION
    ]
    with ProcessPoolExecutor(workers) as pool, out.open("w") as sink:
        for row in pool.map(random_search.race, *zip(*jobs, strict=True)):
            sink.write(json.dumps(row) + "\n")
            sink.flush()


if __name__ == "__main__":
    typer.run(main)
