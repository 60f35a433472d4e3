"""`make results` regenerates every published result: each folder of ``docs/results/`` with a manifest names the
command that wrote it (its README, or the README of the study it belongs to), and that command is one of the
target's (the target's own ``--db`` aside). A result published by hand, or a target that drifted from what the
READMEs say, fails here."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
STUDY = re.compile(r"`(karting (?:reproduce|scenarios run|scenarios oracle|solo)[^`]*)`")
TOURNAMENT = re.compile(r"^\s+(karting tournament run [^\n]*)$", re.MULTILINE)


def _target_commands() -> set[str]:
    dry = subprocess.run(
        ["make", "-n", "results"], cwd=ROOT, capture_output=True, text=True, check=True, env={"PATH": "/usr/bin:/bin"}
    )
    commands = set()
    for line in dry.stdout.splitlines():
        if "karting " not in line:
            continue
        command = line[line.index("karting ") :]
        commands.add(re.sub(r" --db \S+", "", command).strip())
    return commands


def _recorded(folder: Path) -> str | None:
    """The command that regenerates ``folder``: a study's command in its README or its parents' (up to
    ``docs/results/``), else the tournament it publishes."""
    for place in (folder, *folder.parents):
        readme = place / "README.md"
        if readme.is_file() and (found := STUDY.search(readme.read_text())):
            return found.group(1)
        if place == RESULTS:
            break
    readme = folder / "README.md"
    found = TOURNAMENT.search(readme.read_text()) if readme.is_file() else None
    return found.group(1) if found else None


@pytest.mark.skipif(shutil.which("make", path="/usr/bin:/bin") is None, reason="no make")
def test_every_published_result_is_regenerated_by_make_results() -> None:
    commands = _target_commands()
    folders = sorted(p.parent for p in RESULTS.rglob("manifest.json"))
    assert len(folders) >= 9
    for folder in folders:
        recorded = _recorded(folder)
        assert recorded is not None, f"{folder} names no command that regenerates it"
        assert recorded in commands, f"{folder}: `{recorded}` is not in `make results`"
