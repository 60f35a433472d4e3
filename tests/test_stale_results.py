"""The published results describe the agents as they are now: ``docs/results/`` and the README's results table
are what ``karting reproduce paper`` wrote from tournaments whose agents (every parameter, the trained weights),
kart and condition sets resolve the same in today's code. A stale table is an error: run the reproduction again.

How the check itself fails (a changed default, an edited table, a table without a manifest) is tested in
``tests/arena/test_manifest_publish.py`` and ``tests/arena/test_manifest.py``.
"""

from __future__ import annotations

from pathlib import Path

from arena.reproduce import reproduction_problems

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
README = ROOT / "README.md"


def test_the_published_results_are_those_of_the_current_agents() -> None:
    problems = reproduction_problems(RESULTS, README)
    assert problems == [], "stale or unpublished results:\n" + "\n".join(problems)
