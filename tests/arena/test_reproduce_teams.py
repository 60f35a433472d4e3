"""The team reproduction's README: what was run, every agent's team figures per track beside the original's (when
its logs are at hand), every pair with its mirrored pairs, from a small team tournament stored as the server
stores one."""

from __future__ import annotations

from pathlib import Path

import pytest

from arena.reproduce_teams import team_findings, team_spec, team_tournament_id
from arena.tournament import TournamentSpec, run_tournament
from server.db import RaceDatabase
from server.tournament_db import TournamentDatabase

LOGS = Path(__file__).resolve().parents[3] / "shared" / "spec" / "original_logs_teams"


def test_the_team_round_robin_is_the_papers_agents_in_mirrored_pairs() -> None:
    spec = team_spec(4)
    assert spec.team_size == 2 and spec.conditions == "varied" and len(spec.agents) == 5
    assert spec.total == 10 * 2 * 4 and team_tournament_id(4) == "teams-varied-4-s0"
    with pytest.raises(ValueError, match="mirrored pairs"):
        team_spec(3)


def test_the_readme_shows_each_teams_figures_and_each_pair(tmp_path: Path) -> None:
    store = TournamentDatabase(RaceDatabase(f"sqlite:///{tmp_path / 'karting.db'}"))
    spec = TournamentSpec(
        ("fixed-lqng", "lane-follower"), ("oval",), races_per_pair=2, laps=1, time_limit=40.0, team_size=2
    )
    store.create("small-teams", spec)
    run_tournament(spec, store, "small-teams", backend="inline", record=False)
    tournament = store.publishable("small-teams")
    assert tournament is not None
    text = team_findings(tournament, LOGS if LOGS.is_dir() else None)
    assert "tournament `small-teams`, 2 races" in text
    assert "## oval: each agent's team" in text and "## combined: each agent's team" in text
    row = next(line for line in text.splitlines() if line.startswith("| fixed-lqng |"))
    assert "/2 = " in row  # its two races, with an interval
    assert "| fixed-lqng vs lane-follower |" in text and "of 1 |" in text  # one mirrored pair
    if LOGS.is_dir():
        mcts_rl = next(line for line in text.splitlines() if line.startswith("| mcts-rl |"))
        assert "134/192 = 70% [63, 76]" in mcts_rl  # the original's oval figure beside ours ("-": not raced)
    assert "not at hand" in team_findings(tournament, None)
