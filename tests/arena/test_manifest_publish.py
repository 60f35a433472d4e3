"""Publishing a stored tournament (``karting tournament publish``): the report, a README saying what was run and a
manifest listing every file into the results folder, the win table into the README's block; the published folder
checks clean, and goes stale when a default changes, a table is edited or a file appears; what cannot be
published is refused before anything is written."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest
from typer.testing import CliRunner

from arena.publish import (
    BEGIN,
    END,
    MANIFEST_FILE,
    README_TABLE_FILE,
    PublishError,
    Tournament,
    publish,
    published_problems,
    readme_block,
    replace_block,
)
from arena.tournament import TournamentSpec, run_tournament
from karting.cli import app
from server.db import RaceDatabase
from server.tournament_db import TournamentDatabase

SPEC = TournamentSpec(
    agents=("fixed-lqng", "lane-follower"), tracks=("oval",), races_per_pair=2, laps=1, time_limit=30.0, seed=3
)
README = f"# Project\n\nIntro.\n\n{BEGIN}\nno results yet\n{END}\n\nMore.\n"


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A database with the finished tournament ``pub`` and the unfinished ``half``."""
    path = tmp_path_factory.mktemp("publish") / "karting.db"
    store = TournamentDatabase(RaceDatabase(f"sqlite:///{path}"))
    store.create("pub", SPEC)
    run_tournament(SPEC, store, "pub", backend="inline", record=False)
    store.create("half", SPEC)
    run_tournament(SPEC, store, "half", backend="inline", record=False, should_stop=lambda: True)
    return path


def stored(db: Path, tournament_id: str) -> Tournament:
    tournament = TournamentDatabase(RaceDatabase(f"sqlite:///{db}")).publishable(tournament_id)
    assert tournament is not None
    return tournament


def test_the_command_publishes_the_tables_the_manifest_and_the_readme_table(db: Path, tmp_path: Path) -> None:
    out, readme = tmp_path / "docs" / "results", tmp_path / "README.md"
    readme.write_text(README)
    args = ["tournament", "publish", "pub", "--db", str(db), "--out", str(out), "--readme", str(readme), "--json"]
    done = CliRunner().invoke(app, args)
    assert done.exit_code == 0, done.output
    files = {Path(f).name for f in json.loads(done.output.strip().splitlines()[-1])["files"]}
    assert files == {p.name for p in out.iterdir()}
    assert {"README.md", "report.md", "stats.json", "wins_oval.csv", "wins_oval.png", MANIFEST_FILE} <= files
    manifest = json.loads((out / MANIFEST_FILE).read_text())
    assert set(manifest["files"]) == files - {MANIFEST_FILE}
    assert [a["agent"] for a in manifest["agents"]] == ["fixed-lqng", "lane-follower"]
    assert manifest["tournament"]["id"] == "pub" and manifest["tournament"]["races"] == 2
    assert sum(manifest["race_commits"].values()) == 2 and manifest["conditions"]["laps"] == {"oval": 1}
    # the README keeps its text around the block, which is now the win table, linked to the folder
    text = readme.read_text()
    assert text.startswith("# Project\n\nIntro.\n\n") and text.endswith(f"{END}\n\nMore.\n")
    block = readme_block(text)
    assert block is not None and block == (out / README_TABLE_FILE).read_text().strip()
    assert (
        "| agent | vs fixed-lqng | vs lane-follower | wins / races |" in block and "(docs/results/README.md)" in block
    )
    written = (out / "README.md").read_text()
    assert "karting tournament run --id pub --agents fixed-lqng,lane-follower --tracks oval" in written
    for agent in manifest["agents"]:  # every parameter, defaults included
        assert all(f"{key}={json.dumps(value)}" in written for key, value in agent["parameters"].items())
    assert published_problems(out, readme) == []


def test_a_published_folder_goes_stale_when_anything_differs(db: Path, tmp_path: Path) -> None:
    out, readme = tmp_path / "results", tmp_path / "README.md"
    readme.write_text(README)
    publish(stored(db, "pub"), out, readme)
    assert published_problems(out, readme) == []
    path = out / MANIFEST_FILE
    original = path.read_text()
    data = json.loads(original)
    key, now = next(iter(data["agents"][0]["parameters"].items()))
    data["agents"][0]["parameters"][key] = "older"  # as if published before the default changed
    path.write_text(json.dumps(data))
    assert published_problems(out, readme) == [f"stale: fixed-lqng: {key} was 'older', is {now!r} now"]
    path.write_text(original)
    (out / "wins_oval.csv").write_text("agent\nedited by hand\n")
    (out / "extra.csv").write_text("a,b\n")
    readme.write_text(replace_block(README, "| a | b |"))
    assert published_problems(out, readme) == [
        f"{out / 'extra.csv'}: not in {path}",
        f"{out / 'wins_oval.csv'}: changed since it was published",
        f"{readme}: the table between the markers is not {out / README_TABLE_FILE}",
    ]


def test_nothing_published_checks_clean_but_a_table_without_a_manifest_does_not(tmp_path: Path) -> None:
    out, readme = tmp_path / "results", tmp_path / "README.md"
    readme.write_text(README)
    assert published_problems(out, readme) == []  # no folder
    out.mkdir()
    (out / "README.md").write_text("# Results\n\nNone published yet: see `karting tournament publish`.\n")
    readme.write_text(replace_block(README, "| agent | vs e2e | wins / races |\n|---|---|---|\n| e2e | - | |"))
    assert published_problems(out, readme) == []  # an outline without figures is no result
    (out / "wins_combined.csv").write_text("agent,vs e2e\n")
    (out / "README.md").write_text("| agent | wins |\n|---|---|\n| e2e | 3 |\n")
    readme.write_text(replace_block(README, "| agent | wins |\n|---|---|\n| e2e | 3 |"))
    assert published_problems(out, readme) == [
        f"{out / 'README.md'}: a table without a manifest",
        f"{out / 'wins_combined.csv'}: a table without a manifest",
        f"{readme}: a results table between the markers, and no {out / MANIFEST_FILE}",
    ]


def test_what_cannot_be_published_is_refused_before_anything_is_written(db: Path, tmp_path: Path) -> None:
    out, readme = tmp_path / "results", tmp_path / "README.md"
    readme.write_text("# Project without markers\n")
    with pytest.raises(PublishError, match="has no <!-- results:begin -->"):
        publish(stored(db, "pub"), out, readme)
    with pytest.raises(PublishError, match="1 of its 2 races are stored"):
        publish(stored(db, "half"), out, None)
    old = stored(db, "pub")
    with pytest.raises(PublishError, match="no manifest"):
        publish(Tournament(old.id, old.spec, old.total, None, old.races, old.race_manifests), out, None)
    first = old.manifest.agents[0] if old.manifest is not None else None
    assert first is not None and old.manifest is not None
    older = replace(first, parameters={**first.parameters, next(iter(first.parameters)): "older"})
    stale = replace(old, manifest=replace(old.manifest, agents=(older, *old.manifest.agents[1:])))
    with pytest.raises(PublishError) as refused:  # its agents resolve otherwise now, and its races raced others
        publish(stale, out, None)
    assert "stale: fixed-lqng:" in str(refused.value) and "race 0 raced other agents" in str(refused.value)
    assert not out.exists() and readme.read_text() == "# Project without markers\n"
    out.mkdir()
    (out / "README.md").write_text("# Results\n\nNone yet.\n")  # a note without figures: written over
    (out / "paper_grid.json").write_text("{}")
    with pytest.raises(PublishError, match=r"files no publication wrote: \['paper_grid.json'\]"):
        publish(old, out, None)
    cli = ["tournament", "publish", "half", "--db", str(db), "--out", str(tmp_path / "x"), "--no-readme"]
    done = CliRunner().invoke(app, cli)
    assert done.exit_code == 2 and "cannot publish half" in done.output and not (tmp_path / "x").exists()
    with pytest.raises(PublishError, match="once each"):
        replace_block(f"{END}\n{BEGIN}\n", "x")


def test_publishing_again_replaces_the_last_publication(db: Path, tmp_path: Path) -> None:
    out = tmp_path / "results"
    publish(stored(db, "pub"), out, None)
    (out / "wins_complex.csv").write_text("from an earlier publication\n")
    data = json.loads((out / MANIFEST_FILE).read_text())
    data["files"]["wins_complex.csv"] = "0" * 64
    (out / MANIFEST_FILE).write_text(json.dumps(data))
    publish(stored(db, "pub"), out, None)
    assert not (out / "wins_complex.csv").exists() and published_problems(out, None) == []
