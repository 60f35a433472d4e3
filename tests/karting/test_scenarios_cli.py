"""``karting scenarios``: list, run (the JSON summary as the last line, a file with ``--out``) and report; bad
names exit with code 2 and say what was wrong."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from karting.cli import app

runner = CliRunner()


def test_list_run_and_report_a_cell(tmp_path: Path) -> None:
    listed = runner.invoke(app, ["scenarios", "list"], env={"COLUMNS": "200"})
    assert listed.exit_code == 0 and "overtake-corner" in listed.output and "defend-straight" in listed.output
    out = tmp_path / "summary.json"
    args = ["scenarios", "run", "--egos", "fixed-lqng", "--opponents", "lane-follower", "--tracks", "oval"]
    published = tmp_path / "published"
    more = ["--paces", "0.8", "--attempts", "1", "--out", str(out), "--publish", str(published), "--json"]
    done = runner.invoke(app, [*args, *more])
    assert done.exit_code == 0, done.output
    summary = json.loads(done.output.strip().splitlines()[-1])
    (cell,) = summary["cells"]
    assert (cell["ego"], cell["opponent"], cell["pace"], cell["attempts"]) == ("fixed-lqng", "lane-follower", 0.8, 1)
    assert set(cell) >= {"pass_success", "ci95", "collisions_at_fault_per_attempt", "illegal_lane_changes_per_attempt"}
    assert "fixed-lqng" in summary["pass_threshold_r50"]
    assert json.loads(out.read_text()) == summary
    manifest = json.loads((published / "manifest.json").read_text())
    assert manifest["kind"] == "scenarios" and manifest["wall_seconds"] > 0
    assert [a["name"] for a in manifest["agents"]] == ["fixed-lqng", "lane-follower"]
    assert "varied" in manifest["conditions"]["condition_sets"]
    assert "--egos fixed-lqng --opponents lane-follower" in (published / "README.md").read_text()
    markdown = tmp_path / "report.md"
    shown = runner.invoke(app, ["scenarios", "report", str(out), "--markdown", str(markdown)])
    assert (
        shown.exit_code == 0
        and "| overtake-straight | oval | fixed-lqng | lane-follower | 0.8 | 1 |" in markdown.read_text()
    )


def test_bad_names_exit_2_saying_what_was_wrong() -> None:
    unknown = runner.invoke(app, ["scenarios", "run", "--scenarios", "drift"])
    assert unknown.exit_code == 2 and "unknown scenario 'drift'" in unknown.output
    bad_agent = runner.invoke(app, ["scenarios", "run", "--egos", "schumacher"])
    assert bad_agent.exit_code == 2 and "unknown controller 'schumacher'" in bad_agent.output
    bad_pace = runner.invoke(app, ["scenarios", "run", "--paces", "1.5"])
    assert bad_pace.exit_code == 2 and "paces must be in [0.5, 1]" in bad_pace.output


def test_the_staircase_command_prints_its_trials_and_r50() -> None:
    args = ["scenarios", "staircase", "--ego", "fixed-lqng", "--opponent", "lane-follower", "--trials", "2"]
    done = runner.invoke(app, [*args, "--start", "0.8", "--step", "0.05", "--json"])
    assert done.exit_code == 0, done.output
    result = json.loads(done.output.strip().splitlines()[-1])
    assert [t["pace"] for t in result["trials"]] == [0.8, 0.85] and result["r50"] is None  # too few reversals
    bad = runner.invoke(app, [*args, "--scenario", "defend-straight"])
    assert bad.exit_code == 2 and "needs an overtaking scenario" in bad.output


def test_the_oracle_command_checks_its_opponents_and_paces() -> None:
    bad_agent = runner.invoke(app, ["scenarios", "oracle", "--opponents", "schumacher"])
    assert bad_agent.exit_code == 2 and "unknown controller 'schumacher'" in bad_agent.output
    bad_pace = runner.invoke(app, ["scenarios", "oracle", "--paces", "0.2"])
    assert bad_pace.exit_code == 2 and "paces must be in [0.5, 1]" in bad_pace.output


def test_the_oracle_command_checks_its_base_and_the_summaries_beside(tmp_path: Path) -> None:
    not_hierarchical = runner.invoke(app, ["scenarios", "oracle", "--base", "fixed-lqng"])
    assert not_hierarchical.exit_code == 2 and "must be a hierarchical agent" in not_hierarchical.output
    unknown = runner.invoke(app, ["scenarios", "oracle", "--base", "schumacher"])
    assert unknown.exit_code == 2 and "unknown controller 'schumacher'" in unknown.output
    missing = runner.invoke(app, ["scenarios", "oracle", "--beside", str(tmp_path / "none.json")])
    assert missing.exit_code == 2 and "none.json" in missing.output
