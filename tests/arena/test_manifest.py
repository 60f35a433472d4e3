"""Manifests: a stored tournament and each of its races list every agent with every public parameter (defaults
included) and the conditions; the result JSON, the API's models and ``karting race --json`` carry them; records
stored before manifests read back without one; a changed default, parameter or weights file makes a manifest
stale, and a tournament whose agents changed is not resumed."""

from __future__ import annotations

import json
import subprocess
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

import arena.manifest as manifest_module
from arena.manifest import (
    COMMIT_VARIABLE,
    AgentManifest,
    Manifest,
    describe_agent,
    format_agent,
    source_commit,
    stale_agents,
)
from arena.tournament import TournamentSpec, run_tournament
from controllers.parameters import parameter
from controllers.registry import REGISTRY, ControllerSpec, controller_spec, parse_agent
from karting.cli import app
from server.db import RaceDatabase
from server.models import ResultOut
from server.race_config import KartEntry, RaceConfig
from server.results import RaceRecord, live_race_manifest
from server.routes.tournaments import _view
from server.tournament_db import TournamentDatabase, race_id
from sim_core.conditions import condition_set
from sim_core.params import kart_preset
from sim_core.track_io import get_track

SLOW = "fixed-lqng:line_margin_m=1.5"
# one pair, one track, one lap, a short time limit (a race takes well under a second)
SMALL = TournamentSpec(agents=(SLOW, "lane-follower"), tracks=("oval",), races_per_pair=2, laps=1, time_limit=30.0)


def every_parameter(agent: str) -> dict[str, Any]:
    """The agent's parameters as the registry resolves them: its overrides on every default."""
    name, overrides = parse_agent(agent)
    return {p.name: overrides.get(p.name, p.default) for p in controller_spec(name).parameter_list}


def check_agents(manifest: Manifest, agents: tuple[str, ...]) -> None:
    assert [a.agent for a in manifest.agents] == list(agents)
    for entry in manifest.agents:
        assert dict(entry.parameters) == every_parameter(entry.agent) and entry.parameters  # none left out
        assert list(entry.parameters) == [p.name for p in controller_spec(entry.name).parameter_list]
        name, overrides = parse_agent(entry.full)  # the full string builds the same agent
        assert name == entry.name and overrides == dict(entry.parameters)


def test_a_stored_tournament_and_its_races_list_every_parameter_and_the_conditions(tmp_path: Path) -> None:
    database = RaceDatabase(f"sqlite:///{tmp_path / 'karting.db'}")
    store = TournamentDatabase(database)
    store.create("small", SMALL)
    run_tournament(SMALL, store, "small", backend="inline", record=False)
    stored = store.get("small")
    assert stored is not None and stored.manifest is not None
    manifest = stored.manifest
    check_agents(manifest, SMALL.agents)
    assert manifest.agents[0].parameters["line_margin_m"] == 1.5  # the override, every other value the default
    assert manifest.kind == "tournament" and manifest.commit and manifest.kart_preset == "paper"
    assert manifest.kart["top_speed"] > 0 and manifest.machine["cpus"]
    conditions = manifest.conditions
    assert conditions["tracks"] == ["oval"] and conditions["laps"] == {"oval": 1} and conditions["time_limit"] == 30.0
    assert conditions["start_lanes"] == {"even_races": [2, 3], "odd_races": [3, 2]} and conditions["seed"] == 0
    assert conditions["plan_latency"] == 0.1 and conditions["conditions"]["name"] == SMALL.conditions
    assert conditions["conditions"]["start_spread"] == condition_set(SMALL.conditions).start_spread
    # each race's own manifest: made where it raced, stored in its result and shown by the API's model
    for index, lanes in ((0, [2, 3]), (1, [3, 2])):
        race = database.get(race_id("small", index))
        assert race is not None and race.result is not None and race.result.manifest is not None
        check_agents(race.result.manifest, SMALL.agents)
        seed = SMALL.jobs()[index].seed
        assert race.result.manifest.conditions["start_lanes"] == lanes
        assert race.result.manifest.conditions["seed"] == seed
        shown = ResultOut.model_validate(race.result.to_json()).model_dump()
        assert shown["manifest"]["agents"][0]["full"] == manifest.agents[0].full
    view = _view(stored, False).model_dump()["manifest"]
    assert view is not None and view["agents"][0]["parameters"]["line_margin_m"] == 1.5
    assert view["conditions"] == dict(conditions)


def test_records_stored_before_manifests_read_back_without_one(tmp_path: Path) -> None:
    database = RaceDatabase(f"sqlite:///{tmp_path / 'karting.db'}")
    store = TournamentDatabase(database)
    store.create("old", SMALL)
    run_tournament(SMALL, store, "old", backend="inline", record=False)
    race = database.get(race_id("old", 0))
    assert race is not None and race.result is not None
    old = {k: v for k, v in race.result.to_json().items() if k != "manifest"}
    assert RaceRecord.from_json(old).manifest is None
    assert ResultOut.model_validate(old).manifest is None
    with database.engine.begin() as connection:  # a tournament stored before manifests: no manifest row
        connection.exec_driver_sql("DELETE FROM tournament_manifests")
    stored = store.get("old")
    assert stored is not None and stored.manifest is None and _view(stored, False).manifest is None


def test_a_tournament_whose_agents_changed_is_not_resumed(tmp_path: Path) -> None:
    store = TournamentDatabase(RaceDatabase(f"sqlite:///{tmp_path / 'karting.db'}"))
    store.create("t", SMALL)
    store.create("t", SMALL)  # unchanged: resumes
    with store.db.engine.begin() as connection:  # as if a default had changed since it started
        (text,) = connection.exec_driver_sql("SELECT manifest FROM tournament_manifests").one()
        data = json.loads(text)
        data["agents"][1]["parameters"][next(iter(data["agents"][1]["parameters"]))] = 123456
        connection.exec_driver_sql("UPDATE tournament_manifests SET manifest = ?", (json.dumps(data),))
    with pytest.raises(ValueError, match=r"cannot resume: its agents changed.*lane-follower"):
        store.create("t", SMALL)


@dataclass(frozen=True)
class ToyParams:
    """A toy controller's parameters."""

    gain: float = parameter(1.0, "a gain", minimum=0.0, maximum=10.0)
    smooth: bool = parameter(True, "smooth it")


@dataclass(frozen=True)
class NewToyParams:
    """The toy's parameters after a change of default and a new parameter."""

    gain: float = parameter(2.0, "a gain", minimum=0.0, maximum=10.0)
    smooth: bool = parameter(True, "smooth it")
    window: int = parameter(3, "a new parameter", minimum=1, maximum=9)


def toy_lookup(params_type: type) -> Any:
    """A registry with one controller, ``toy``, whose parameters are ``params_type``."""
    base = REGISTRY["lane-follower"]
    toy: ControllerSpec[Any] = replace(base, name="toy", params_type=params_type)
    return lambda name: {"toy": toy}[name]


def test_a_changed_default_a_new_parameter_or_new_weights_make_a_manifest_stale() -> None:
    before, after = toy_lookup(ToyParams), toy_lookup(NewToyParams)
    entry = describe_agent("toy:smooth=false", before)
    assert entry.parameters == {"gain": 1.0, "smooth": False} and entry.full == "toy:gain=1.0:smooth=false"
    manifest = Manifest("tournament", "abc", False, (entry,), "paper", {}, {})
    assert stale_agents(manifest, before) == []
    assert stale_agents(manifest, after) == [
        "toy:smooth=false: gain was 1.0, is 2.0 now",
        "toy:smooth=false: window = 3 is a new parameter",
    ]
    # an override holds its value through a change of default: only what the agent string leaves open moves
    pinned = Manifest("tournament", "abc", False, (describe_agent("toy:gain=2:window=3", after),), "paper", {}, {})
    assert stale_agents(pinned, after) == []
    retrained = replace(entry, weights={"path": "w/policy.npz", "sha256": "0" * 64})
    assert "its trained weights changed" in stale_agents(replace(manifest, agents=(retrained,)), before)[0]
    gone = Manifest("race", "abc", None, (AgentManifest("ghost", "ghost", {}),), "paper", {}, {})
    assert stale_agents(gone) == ["ghost: controller 'ghost' is no longer registered"]
    kart = replace(manifest, kart={**asdict(kart_preset("paper")), "top_speed": 99.0})
    assert stale_agents(kart, before) == ["kart preset 'paper': top_speed changed"]


def test_agent_strings_with_every_parameter_read_back_as_written() -> None:
    for name in REGISTRY:
        entry = describe_agent(name)
        assert parse_agent(entry.full) == (name, dict(entry.parameters))
    assert format_agent("x", {"label": "3", "name": "oval", "on": True}) == 'x:label="3":name=oval:on=true'
    assert parse_agent('x:label="3":name=oval:on=true')[1] == {"label": "3", "name": "oval", "on": True}


def test_a_live_race_and_a_headless_race_carry_their_manifests() -> None:
    karts = (KartEntry(0, "a", "fixed-lqng", {"line_margin_m": 0.8}), KartEntry(1, "me", "human"))
    config = RaceConfig("oval", get_track("oval"), 2, 4, None, "paper", karts)
    manifest = live_race_manifest(config, 0.3, REGISTRY)
    assert manifest is not None and [a.agent for a in manifest.agents] == ["fixed-lqng:line_margin_m=0.8", "human"]
    assert manifest.agents[0].parameters == every_parameter("fixed-lqng:line_margin_m=0.8")
    assert manifest.conditions["start_lanes"] == [2, 3] and manifest.conditions["plan_budget_s"] == 0.3
    assert live_race_manifest(config, 0.3, {}) is None  # a controller it cannot describe: no manifest, no error
    args = ["race", "--karts", "fixed-lqng,lane-follower:lookahead_time=0.5", "--laps", "1", "--seed", "2", "--json"]
    done = CliRunner().invoke(app, args)
    assert done.exit_code == 0, done.output
    headless = json.loads(done.output.strip().splitlines()[-1])["manifest"]
    assert headless["kind"] == "race" and headless["conditions"]["laps"] == 1 and headless["conditions"]["seed"] == 2
    assert headless["agents"][1]["parameters"] == every_parameter("lane-follower:lookahead_time=0.5")


def test_the_commit_is_gits_or_named_outside_a_checkout(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    source_commit.cache_clear()
    commit, dirty = source_commit()
    if (manifest_module.ROOT / ".git").exists():
        assert len(commit) == 40 and int(commit, 16) >= 0 and dirty in (True, False)
    monkeypatch.setattr(manifest_module, "ROOT", tmp_path)  # a copy of the tree, not a checkout
    monkeypatch.delenv(COMMIT_VARIABLE, raising=False)
    source_commit.cache_clear()
    assert source_commit() == ("unknown", None)
    monkeypatch.setenv(COMMIT_VARIABLE, "0123abc")
    source_commit.cache_clear()
    assert source_commit() == ("0123abc", None)
    source_commit.cache_clear()


def test_changed_results_and_docs_do_not_count_as_changed_code(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """`make results` publishes one result before racing the next: the published files it has written are no code
    the next races run, so they leave the manifest clean; an edited source file does not."""

    def git(*args: str) -> None:
        subprocess.run(["git", "-C", str(tmp_path), "-c", "user.email=t@t", "-c", "user.name=t", *args], check=True)

    (tmp_path / "docs" / "results").mkdir(parents=True)
    for name in ("code.py", "README.md", "docs/results/table.md"):
        (tmp_path / name).write_text("before\n")
    git("init", "-q")
    git("add", ".")
    git("commit", "-qm", "start")
    monkeypatch.setattr(manifest_module, "ROOT", tmp_path.resolve())
    (tmp_path / "README.md").write_text("after\n")
    (tmp_path / "docs" / "results" / "table.md").write_text("after\n")
    source_commit.cache_clear()
    assert source_commit()[1] is False
    (tmp_path / "code.py").write_text("after\n")
    source_commit.cache_clear()
    assert source_commit()[1] is True
    source_commit.cache_clear()


def test_the_command_line_shows_and_writes_a_tournaments_manifest(tmp_path: Path) -> None:
    db = str(tmp_path / "k.db")
    args = ["tournament", "run", "--agents", f"{SLOW},lane-follower", "--tracks", "oval", "--races-per-pair", "1"]
    args += ["--laps", "1", "--time-limit", "30", "--workers", "1", "--id", "m", "--db", db]
    done = CliRunner().invoke(app, [*args, "--json"])
    assert done.exit_code == 0, done.output
    shown = json.loads(done.output.strip().splitlines()[-1])["manifest"]
    assert shown["kind"] == "tournament" and shown["agents"][0]["parameters"] == every_parameter(SLOW)
    out = tmp_path / "report"
    report = CliRunner().invoke(app, ["tournament", "report", "m", "--db", db, "--out", str(out)])
    assert report.exit_code == 0, report.output
    assert json.loads((out / "manifest.json").read_text()) == shown
