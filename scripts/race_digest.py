"""The race digest: a fixed set of short headless races whose every simulation step is hashed.

Every registered agent races on ``oval`` and ``complex`` from both start lanes, for the first
``DIGEST_SECONDS`` of simulated time (the start, the first corners and the first traffic, where the tactical
layers act). The SHA-256 of each race's kart state after every step is stored in
``tests/golden/race_digest.json``; ``tests/test_race_digest.py`` re-runs the races and compares. A refactor
that must not change behaviour keeps every hash; a deliberate behaviour change regenerates the file:

    .venv/bin/python scripts/race_digest.py --write
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from controllers.base import Controller
from controllers.race import RaceSpec, run_race
from sim_core.world import World

GOLDEN = Path(__file__).resolve().parent.parent / "tests" / "golden" / "race_digest.json"
DIGEST_SECONDS = 20.0
TRACKS = ("oval", "complex")
# every registered agent appears at least twice, against a planner of the other family where it has one
PAIRS = (
    ("mcts-lqng", "fixed-lqng"),
    ("mcts-rl", "fixed-rl"),
    ("mcts-lqng", "mcts-rl"),
    ("e2e", "lane-follower"),
)


def race_names() -> list[str]:
    """The digest's races as ``TRACK/AGENT_A-vs-AGENT_B`` (kart 0 first: it starts in lane 2, the other in 3)."""
    names: list[str] = []
    for track in TRACKS:
        for a, b in PAIRS:
            names.extend((f"{track}/{a}-vs-{b}", f"{track}/{b}-vs-{a}"))
    return names


def race_hash(name: str) -> str:
    """The SHA-256 over every step's float, int and race state of race ``name`` (see :func:`race_names`)."""
    track, pair = name.split("/")
    first, second = pair.split("-vs-")
    digest = hashlib.sha256()

    def absorb(world: World, drivers: Sequence[Controller], step: int) -> None:
        digest.update(world.fstate.tobytes())
        digest.update(world.istate.tobytes())
        digest.update(world.rstate.tobytes())

    spec = RaceSpec(track=track, controllers=(first, second), seed=0, start_lanes=(2, 3), time_limit=DIGEST_SECONDS)
    run_race(spec, on_step=absorb)
    return digest.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"write {GOLDEN.name} instead of comparing with it")
    args = parser.parse_args()
    hashes = {name: race_hash(name) for name in race_names()}
    if args.write:
        GOLDEN.parent.mkdir(parents=True, exist_ok=True)
        GOLDEN.write_text(json.dumps(hashes, indent=1) + "\n")
        print(json.dumps({"written": str(GOLDEN), "races": len(hashes)}))
        return
    stored = json.loads(GOLDEN.read_text())
    differ = sorted(name for name in hashes if stored.get(name) != hashes[name])
    print(json.dumps({"races": len(hashes), "differ": differ}))
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
