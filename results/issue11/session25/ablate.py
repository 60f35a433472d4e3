"""Which of a found setting's entries win the lane-2 start of `complex` (``random_search.py``'s races): the
setting, the setting less one entry at a time (put back as registered), and the registered mcts-lqng with one
entry at a time; optionally fixed-lqng given the same tracker fields (``--control``).

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session25/ablate.py device1/random_search.jsonl 529
"""

from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import typer

sys.path.insert(0, str(Path(__file__).parent))
import random_search


def main(results: Path, config: int, workers: int = 2, track: str = "complex", lane: int = 2, seed: int = 0) -> None:
    """One race per variant of setting ``config`` from ``results``."""
    setting = next(json.loads(line)["setting"] for line in results.open() if json.loads(line)["config"] == config)
    variants: list[tuple[str, dict[str, dict[str, Any]]]] = [
        ("found", setting),
        ("registered", {"public": {}, "tracker": {}}),
    ]
    for part, values in setting.items():
        for key in values:
            less = {p: {k: v for k, v in vs.items() if not (p == part and k == key)} for p, vs in setting.items()}
            variants.append((f"without {key}", less))
            only: dict[str, dict[str, Any]] = {"public": {}, "tracker": {}}
            only[part] = {key: values[key]}
            variants.append((f"only {key}", only))
    with ProcessPoolExecutor(workers) as pool:
        futures = [(name, pool.submit(random_search.race, config, v, track, lane, seed)) for name, v in variants]
        for name, future in futures:
            row = future.result()
            print(
                json.dumps({"variant": name} | {k: row[k] for k in ("won", "margin", "times", "faults", "passes")}),
                flush=True,
            )


if __name__ == "__main__":
    typer.run(main)
