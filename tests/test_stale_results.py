"""The published results describe the agents as they are now: ``docs/results/`` and the README's results table
are what ``karting reproduce paper`` wrote from tournaments whose agents (every parameter, the trained weights),
kart and condition sets resolve the same in today's code. A stale table is an error: run the reproduction again.

How the check itself fails (a changed default, an edited table, a table without a manifest) is tested in
``tests/arena/test_manifest_publish.py`` and ``tests/arena/test_manifest.py``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from arena.manifest import describe_agent
from arena.publish import published_problems
from arena.reproduce import reproduction_problems, stale_conditions

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
README = ROOT / "README.md"


def test_the_published_results_are_those_of_the_current_agents() -> None:
    problems = reproduction_problems(RESULTS, README)
    assert problems == [], "stale or unpublished results:\n" + "\n".join(problems)


def _published_tournaments() -> list[Path]:
    """Every folder under docs/results/ holding a published tournament, besides the reproduction's two."""
    found = []
    for manifest in sorted(RESULTS.rglob("manifest.json")):
        folder = manifest.parent
        if folder.parent == RESULTS and folder.name in ("paper", "varied"):
            continue
        if json.loads(manifest.read_text()).get("kind") == "tournament":
            found.append(folder)
    return found


def test_every_other_published_tournament_is_of_the_current_agents_and_conditions() -> None:
    folders = _published_tournaments()
    assert folders, "no other published tournament found: the check would pass on nothing"
    problems = []
    for folder in folders:
        conditions = json.loads((folder / "manifest.json").read_text())["conditions"]["conditions"]["name"]
        problems += [f"{folder}: {p}" for p in published_problems(folder, None)]
        problems += [f"{folder}: {p}" for p in stale_conditions(folder, conditions)]
    assert problems == [], "stale published tournaments:\n" + "\n".join(problems)


@pytest.mark.parametrize("kind", ["field", "scenarios", "solo"])
def test_every_published_study_is_of_the_current_agents(kind: str) -> None:
    """A field study (``karting reproduce field``), a scenario suite (``karting scenarios run|oracle
    --publish``) or the solo laps (``karting solo --publish``) records each agent with every parameter and its
    weights: each must describe the same agent today. (A field study's manifest names its condition set without
    the set's values, so a changed set is not caught here.)"""
    folders = [m.parent for m in sorted(RESULTS.rglob("manifest.json")) if json.loads(m.read_text())["kind"] == kind]
    assert folders, f"no published {kind} result found: the check would pass on nothing"
    problems = []
    for folder in folders:
        manifest = json.loads((folder / "manifest.json").read_text())
        for recorded in manifest["agents"]:
            if describe_agent(recorded["agent"]).to_json() != recorded:
                problems.append(f"{folder}: {recorded['agent']} is no longer the agent it raced: race it again")
    assert problems == [], f"stale {kind} results:\n" + "\n".join(problems)
