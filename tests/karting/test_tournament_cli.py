"""``karting tournament``: the statistics of the original's logs as JSON, a reduced grid run and reported (Markdown,
CSV, JSON and PNG files), resuming a finished tournament runs nothing, and bad input exits with 2."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from karting.cli import app

LOGS = Path(__file__).resolve().parents[3] / "shared" / "spec" / "original_logs"
runner = CliRunner()
ENV = {"COLUMNS": "80"}


@pytest.mark.skipif(not LOGS.is_dir(), reason=f"the original's race logs are not at {LOGS} (kept outside the repo)")
def test_stats_of_the_original_logs_prints_the_stats_json() -> None:
    done = runner.invoke(app, ["tournament", "stats", "--original-logs", str(LOGS), "--json"], env=ENV)
    assert done.exit_code == 0, done.output
    data = json.loads(done.output.strip().splitlines()[-1])
    assert list(data["tracks"]) == ["oval", "complex", "combined"]
    assert data["tracks"]["combined"]["wins"]["mcts-rl"]["e2e"] == 97
    assert data["tracks"]["combined"]["safety"]["fixed-lqng"]["finished"] == 392


def test_a_reduced_grid_runs_resumes_and_reports(tmp_path: Path) -> None:
    db = tmp_path / "karting.db"
    args = ["tournament", "run", "--agents", "fixed-lqng,lane-follower", "--tracks", "oval", "--races-per-pair", "2"]
    args += ["--laps", "1", "--time-limit", "30", "--workers", "2", "--db", str(db), "--id", "cli"]
    done = runner.invoke(app, args, env=ENV)
    assert done.exit_code == 0, done.output
    assert "tournament cli: 2 races, 0 stored already" in done.output and "wins (oval)" in done.output
    assert max(len(line) for line in done.output.splitlines()) <= 80 and "…" not in done.output
    assert {"fixed-lqng", "lane-follower"} <= set(done.output.split())  # the agents' names whole at 80 columns
    again = runner.invoke(app, [*args, "--json"], env=ENV)
    assert again.exit_code == 0 and "2 stored already" in again.output
    summary = json.loads(again.output.strip().splitlines()[-1])
    assert summary["id"] == "cli" and summary["tracks"]["oval"]["safety"]["fixed-lqng"]["races"] == 2
    stats = runner.invoke(app, ["tournament", "stats", "--id", "cli", "--db", str(db), "--json"], env=ENV)
    assert json.loads(stats.output)["tracks"]["oval"]["safety"]["lane-follower"]["races"] == 2
    out = tmp_path / "report"
    report = runner.invoke(app, ["tournament", "report", "cli", "--db", str(db), "--out", str(out), "--json"], env=ENV)
    assert report.exit_code == 0, report.output
    written = json.loads(report.output.strip().splitlines()[-1])
    assert written["folder"] == str(out) and {Path(f).name for f in written["files"]} == {p.name for p in out.iterdir()}
    names = {p.name for p in out.iterdir()}
    assert {"report.md", "stats.json", "wins_oval.csv", "safety_oval.csv", "plan_oval.csv"} <= names
    assert {"wins_oval.png", "safety_oval.png", "finish_times.png"} <= names
    assert (out / "wins_oval.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    markdown = (out / "report.md").read_text()
    assert "| agent | vs fixed-lqng | vs lane-follower |" in markdown
    assert json.loads((out / "stats.json").read_text()) == json.loads(stats.output)


def test_bad_tournaments_exit_with_2(tmp_path: Path) -> None:
    db = str(tmp_path / "k.db")
    unknown = runner.invoke(app, ["tournament", "run", "--agents", "fixed-lqng,nope", "--db", db], env=ENV)
    assert unknown.exit_code == 2 and "nope" in unknown.output
    backend = runner.invoke(app, ["tournament", "run", "--agents", "e2e,fixed-rl", "--backend", "x", "--db", db])
    assert backend.exit_code == 2 and "unknown backend" in backend.output
    wet = runner.invoke(app, ["tournament", "run", "--agents", "e2e,fixed-rl", "--conditions", "wet", "--db", db])
    assert wet.exit_code == 2 and "unknown conditions 'wet'" in wet.output
    neither = runner.invoke(app, ["tournament", "stats"], env=ENV)
    assert neither.exit_code == 2
    missing = runner.invoke(app, ["tournament", "report", "nope", "--db", db], env=ENV)
    assert missing.exit_code == 2 and "no tournament" in missing.output


TEAM_LOGS = LOGS.parent / "original_logs_teams"


@pytest.mark.skipif(not TEAM_LOGS.is_dir(), reason=f"the original's team logs are not at {TEAM_LOGS}")
def test_stats_of_the_original_team_logs_print_team_tables_and_defects() -> None:
    args = ["tournament", "stats", "--original-logs", str(TEAM_LOGS), "--teams"]
    done = runner.invoke(app, args, env=ENV)
    assert done.exit_code == 0, done.output
    assert "as the original's parser counts" in done.output and "byte copy" in done.output
    data = json.loads(runner.invoke(app, [*args, "--json"], env=ENV).output.strip().splitlines()[-1])
    assert data["parser"]["combined"]["mcts-rl"]["wins"] == 254 and len(data["matchups"]) == 19
    refused = runner.invoke(app, ["tournament", "stats", "--id", "x", "--teams"], env=ENV)
    assert refused.exit_code == 2 and "--teams reads the original's team logs" in refused.output


def test_a_team_tournament_prints_its_team_table(tmp_path: Path) -> None:
    args = ["tournament", "run", "--agents", "fixed-lqng,lane-follower", "--tracks", "oval", "--races-per-pair", "2"]
    args += ["--laps", "1", "--time-limit", "40", "--team-size", "2", "--workers", "1", "--db", str(tmp_path / "t.db")]
    done = runner.invoke(app, [*args, "--id", "teams"], env=ENV)
    assert done.exit_code == 0, done.output
    assert "teams (oval)" in done.output and "fixed-lqng vs lane-follower" in done.output
    odd = runner.invoke(app, [*args[:-2], "--db", str(tmp_path / "u.db"), "--races-per-pair", "3"], env=ENV)
    assert odd.exit_code == 2 and "mirrored pairs" in odd.output
