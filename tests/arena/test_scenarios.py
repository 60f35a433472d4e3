"""The tactics suite: scenarios as data, placed rolling starts, paired attempt seeds, the judgement of an attempt,
the figures and the pass threshold, and a CI-sized run of real cells."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from arena.intervals import wilson
from arena.scenario_report import beside_oracle, markdown_report
from arena.scenario_setups import Attempt, attempt_specs, longest_straight, placements
from arena.scenario_spec import Cell, Scenario, load_scenario, shipped_scenarios
from arena.scenarios import CellFigures, SuiteResult, cells_of, pass_thresholds, run_cells
from sim_core.track_io import get_track


def test_the_shipped_scenarios_load_and_a_bad_file_says_what_is_wrong(tmp_path: Path) -> None:
    assert {"overtake-straight", "overtake-corner", "defend-straight"} <= set(shipped_scenarios())
    assert load_scenario("defend-straight").kind == "defend"
    with pytest.raises(KeyError, match="unknown scenario 'nope'"):
        load_scenario("nope")
    bad = tmp_path / "mine.json"
    bad.write_text(json.dumps({"name": "mine", "kind": "overtake", "paces": [0.2], "gap_m": [30, 10]}))
    with pytest.raises(ValueError, match=r"gap_m must be .*paces must be in \[0.5, 1\]"):
        load_scenario(str(bad))
    bad.write_text(json.dumps({"name": "mine", "kind": "overtake", "speed": 3}))
    with pytest.raises(ValueError, match=r"unknown fields \['speed'\]"):
        load_scenario(str(bad))
    mine = Scenario("mine", "overtake", tracks=("oval",), paces=(0.9,))
    bad.write_text(json.dumps(mine.to_json()))
    assert load_scenario(str(bad)) == mine  # a user's own file round-trips


def test_the_follower_rolls_the_gap_behind_the_leader_on_the_longest_straight() -> None:
    oval = get_track("oval")
    start, end = longest_straight(oval)
    assert end - start > 50.0  # the oval's straights are about 60 m
    scenario = load_scenario("overtake-straight")
    lead, follow = placements(scenario, oval, 12.5, 0.95)
    assert lead.progress - follow.progress == pytest.approx(12.5)

    def along(s: float) -> float:  # progress counted from the straight's start (it may run over the line)
        return start + (s - start) % oval.length

    assert start < along(follow.progress) < along(lead.progress) < end
    assert lead.lane == follow.lane and lead.speed == follow.speed <= 0.95 * 15.0
    corner_lead, _ = placements(replace(scenario, place="corner"), oval, 12.5, 0.95)
    assert corner_lead.progress == pytest.approx(end - 35.0)


def test_attempt_i_has_the_same_seed_and_gap_in_every_cell_of_a_scenario_on_a_track() -> None:
    scenario = load_scenario("overtake-straight")
    cells = cells_of(scenario, ["mcts-lqng", "fixed-rl"], ["fixed-lqng"], tracks=["oval"], paces=[0.9, 0.97])
    assert len(cells) == 4
    runs = [attempt_specs(scenario, cell, 3) for cell in cells]
    for i in range(3):
        assert len({specs[i].seed for specs in runs}) == 1
        assert len({specs[i].placements[1].progress - specs[i].placements[0].progress for specs in runs}) == 1
    assert len({spec.seed for spec in runs[0]}) == 3
    ego, leader = runs[0][0].controllers
    assert (ego, leader) == ("mcts-lqng", "fixed-lqng@0.9")  # overtake: the leader is handicapped
    defend = attempt_specs(load_scenario("defend-straight"), Cell("defend-straight", "oval", "mcts-rl", "e2e", 0.97), 1)
    assert defend[0].controllers == ("mcts-rl@0.97", "e2e")  # defend: the ego is
    assert defend[0].placements[0].progress > defend[0].placements[1].progress  # and it leads
    with pytest.raises(ValueError, match="carries its own pace"):
        Cell("s", "oval", "mcts-lqng", "fixed-lqng@0.9", 0.95).agents("overtake")


def _figures(ego: str, opponent: str, pace: float, wins: int, n: int) -> CellFigures:
    attempts = [Attempt(i < wins, 10.0 if i < wins else None, 0, 0, 0) for i in range(n)]
    return CellFigures.of(Cell("s", "oval", ego, opponent, pace), attempts)


def test_figures_and_the_pass_threshold_are_computed_by_hand() -> None:
    f = _figures("a", "b", 0.95, 7, 10)
    assert f.pass_success == 0.7 and f.ci95 == wilson(7, 10) and f.time_to_pass == 10.0
    figures = [
        _figures("a", "b", 0.93, 9, 10),
        _figures("a", "b", 0.95, 5, 10),  # exactly half passes
        _figures("a", "b", 0.97, 4, 10),
        _figures("a", "c", 0.93, 4, 10),
        _figures("a", "c", 0.93, 1, 10),  # pooled over tracks: 5 / 20
    ]
    assert pass_thresholds(figures) == {"a": {"b": 0.95, "c": None}}


def test_a_ci_sized_run_of_real_cells_passes_a_slow_leader_and_reports_it(tmp_path: Path) -> None:
    """mcts-lqng behind fixed-lqng at pace 0.9 on the oval passes in both attempts and breaks no rule; the
    summary and its Markdown report carry the cell."""
    scenario = replace(load_scenario("overtake-straight"), laps=2)
    cells = cells_of(scenario, ["mcts-lqng"], ["fixed-lqng"], tracks=["oval"], paces=[0.9])
    (figures,) = run_cells(scenario, cells, attempts=2)
    assert figures.attempts == 2 and figures.successes == 2
    assert figures.time_to_pass is not None and 0.0 < figures.time_to_pass < 60.0
    assert figures.collisions_at_fault_per_attempt == 0.0 and figures.illegal_lane_changes_per_attempt == 0.0
    summary = SuiteResult(((scenario, (figures,)),), 2, 0).to_json()
    assert summary["pass_threshold_r50"] == {"mcts-lqng": {"fixed-lqng": 0.9}}
    assert summary["cells"][0]["ci95"] == [wilson(2, 2).low, wilson(2, 2).high]  # type: ignore[union-attr]
    assert "| overtake-straight | oval | mcts-lqng | fixed-lqng | 0.9 | 2 | 1.00 [0.34, 1.00]" in markdown_report(
        summary
    )


def _cell(ego: str, opponent: str, pace: float, success: float, attempts: int = 10) -> dict[str, object]:
    return {
        "scenario": "overtake-straight",
        "track": "oval",
        "ego": ego,
        "opponent": opponent,
        "pace": pace,
        "attempts": attempts,
        "pass_success": success,
        "ci95": [0.0, 1.0],
    }


def test_the_agents_beside_the_oracle_are_its_base_ego_on_the_cells_both_ran() -> None:
    oracle = {
        "oracle": {"base": "mcts-lqng", "lookahead_s": 4.0},
        "cells": [_cell("oracle", "e2e", 0.95, 0.8), _cell("oracle", "e2e", 0.97, 0.0)],
    }
    agents = {
        "command": "--egos mcts-lqng,mcts-rl",
        "cells": [
            _cell("mcts-lqng", "e2e", 0.95, 0.6, 30),
            _cell("mcts-rl", "e2e", 0.95, 0.9, 30),  # another ego's tracker: not compared
            _cell("mcts-lqng", "e2e", 0.97, 0.1, 30),
            _cell("mcts-lqng", "fixed-rl", 0.95, 0.5, 30),  # a cell the oracle did not run
        ],
    }
    text = "\n".join(beside_oracle(oracle, agents))
    rows = [line for line in text.splitlines() if line.startswith("| oval")]
    assert rows == [
        "| oval | e2e | 0.95 | 0.80 [0.00, 1.00] (10) | mcts-lqng | 0.60 [0.00, 1.00] (30) | 0.75 |",
        "| oval | e2e | 0.97 | 0.00 [0.00, 1.00] (10) | mcts-lqng | 0.10 [0.00, 1.00] (30) |  |",
    ]
    assert "`karting scenarios run --egos mcts-lqng,mcts-rl`" in text
