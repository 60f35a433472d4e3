"""Publishing a stored tournament's results (``karting tournament publish``) and checking published ones.

:func:`publish` writes a finished tournament's report (:func:`arena.report.write_report`: Markdown, CSV, JSON and
PNG), a ``README.md`` saying what was run, the README's results table (``readme_table.md``) and ``manifest.json``:
the tournament's manifest (:mod:`arena.manifest`), the commits its races ran at, and the SHA-256 of every file
written. It then puts that table between the markers :data:`BEGIN` and :data:`END` of the project's README. It
refuses a tournament that is unfinished, has no manifest, mixes agents, or whose agents resolve differently now.

:func:`published_problems` checks a published folder against the registry of this checkout: a stale table is an
error (``tests/test_stale_results.py``).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shlex
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from arena.manifest import Manifest, SpecLookup, source_commit, stale_agents
from arena.records import RaceFigures
from arena.report import markdown_table, safety_rows, win_rows, write_report
from arena.stats import COMBINED, TournamentStats, TrackStats, tournament_stats
from controllers.registry import controller_spec

BEGIN = "<!-- results:begin -->"
END = "<!-- results:end -->"
MANIFEST_FILE = "manifest.json"
README_FILE = "README.md"
README_TABLE_FILE = "readme_table.md"  # the README's results table, as put between its markers
WIDTH = 116  # prose line width of the Markdown written


class PublishError(ValueError):
    """The tournament cannot be published (or the README cannot take its table): every reason, one per line."""


@dataclass(frozen=True)
class Tournament:
    """A stored tournament, as publishing reads it."""

    id: str
    spec: Mapping[str, Any]  # arena.tournament.TournamentSpec.to_json()
    total: int  # races in its schedule
    manifest: Manifest | None  # None: stored before manifests were kept
    races: Sequence[RaceFigures]  # its stored races
    race_manifests: Sequence[Manifest | None]  # each stored race's, in the same order


def publish_problems(tournament: Tournament, lookup: SpecLookup = controller_spec) -> list[str]:
    """Why ``tournament`` cannot be published (empty: it can)."""
    problems = []
    if len(tournament.races) < tournament.total:
        problems.append(f"{len(tournament.races)} of its {tournament.total} races are stored: finish it first")
    recorded = tournament.manifest
    if recorded is None:
        return [*problems, "it has no manifest (stored before manifests were kept): run it again"]
    agents = {a.agent: a.to_json() for a in recorded.agents}
    for race, race_manifest in zip(tournament.races, tournament.race_manifests, strict=True):
        if race_manifest is None:
            problems.append(f"race {race.index} has no manifest")
        elif any(agents.get(a.agent) != a.to_json() for a in race_manifest.agents):
            problems.append(f"race {race.index} raced other agents than the tournament's manifest lists")
    return problems + [f"stale: {p}" for p in stale_agents(recorded, lookup)]


def replace_block(text: str, block: str) -> str:
    """``text`` with what lies between the lines :data:`BEGIN` and :data:`END` replaced by ``block``;
    :class:`PublishError` unless each marker is there once, in that order."""
    begin, end = text.count(BEGIN), text.count(END)
    if begin != 1 or end != 1 or text.index(BEGIN) > text.index(END):
        raise PublishError(f"it needs the markers {BEGIN} and {END} once each, in that order (found {begin}, {end})")
    head, rest = text.split(BEGIN)
    _old, tail = rest.split(END)
    return f"{head}{BEGIN}\n{block.strip()}\n{END}{tail}"


def readme_block(text: str) -> str | None:
    """What lies between the markers of ``text`` (``None``: no markers)."""
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        return None
    return text.split(BEGIN)[1].split(END)[0].strip()


def totals_rows(table: TrackStats) -> list[list[str]]:
    """The win table (:func:`arena.report.win_rows`) with each agent's wins / races."""
    rows = win_rows(table)
    out = [[*rows[0], "wins / races"]]
    for row in rows[1:]:
        agent = row[0]
        wins, races = sum(table.wins[agent].values()), table.agent_stats[agent].races
        out.append([*row, f"{wins} / {races} ({100 * wins / races:.0f}%)" if races else "-"])
    return out


def _short(commit: str) -> str:
    return commit[:10] if commit != "unknown" else commit


def _wrap(text: str, indent: str = "") -> str:
    """``text`` wrapped at :data:`WIDTH` (Markdown paragraphs and list items; code spans are not split)."""
    return textwrap.fill(text, WIDTH, subsequent_indent=indent, break_long_words=False, break_on_hyphens=False)


def _races(n: int) -> str:
    return f"{n} race" if n == 1 else f"{n} races"


def readme_table(stats: TournamentStats, tournament: Tournament, folder: str) -> str:
    """The README's results table: wins over every track, row agent against column agent, and what it is."""
    recorded = tournament.manifest
    assert recorded is not None
    spec = tournament.spec
    tracks = ", ".join(f"`{t}`" for t in spec["tracks"])
    text = _wrap(
        f"Tournament `{tournament.id}`: {_races(spec['races_per_pair'])} per pair and track on {tracks}, commit "
        f"{_short(recorded.commit)}. Wins over all tracks, row agent against column agent (`*`: significant at "
        f"p = 0.05). Written by `karting tournament publish`; the agents' parameters, the conditions and the "
        f"per-track tables are in [`{folder}/`]({folder}/README.md)."
    )
    return f"{text}\n\n{markdown_table(totals_rows(stats.tracks[COMBINED]))}"


def run_command(tournament_id: str, spec: Mapping[str, Any]) -> str:
    """The ``karting tournament run`` command that races ``spec`` again."""
    args = ["karting", "tournament", "run", "--id", tournament_id, "--agents", ",".join(spec["agents"])]
    args += ["--tracks", ",".join(spec["tracks"]), "--races-per-pair", str(spec["races_per_pair"])]
    args += ["--seed", str(spec["seed"]), "--kart", str(spec["kart_preset"])]
    for option, key in (("--laps", "laps"), ("--time-limit", "time_limit")):
        if spec.get(key) is not None:
            args += [option, str(spec[key])]
    args += ["--conditions", str(spec.get("conditions", "paper"))]
    return shlex.join(args)


def _conditions(conditions: Mapping[str, Any]) -> str:
    """The race conditions a manifest records, in words (stored before they were a named set: a launch spread)."""
    drawn = conditions.get("conditions")
    if not isinstance(drawn, Mapping):
        return f"a launch spread of {conditions.get('start_spread', 0.0)} s"
    return f"`{drawn.get('name')}` ({drawn.get('description') or json.dumps(drawn)})"


def _what_was_run(tournament: Tournament, race_commits: Mapping[str, int]) -> list[str]:
    """The bullets of ``README.md``'s "What was run"."""
    recorded = tournament.manifest
    assert recorded is not None
    c = recorded.conditions
    dirty = {True: " (tracked files differed from it)", False: "", None: " (whether tracked files differed: unknown)"}
    commits = ", ".join(f"{_short(commit)} ({_races(n)})" for commit, n in race_commits.items())
    laps = ", ".join(f"`{track}` {n}" for track, n in dict(c.get("laps") or {}).items())
    lanes = dict(c.get("start_lanes") or {})
    background = dict(c.get("background_planner") or {})
    settings_of = background.pop("settings_of", "-")
    planned = ", ".join(f"`{a}`" for a in c.get("background_planners") or []) or "none"
    machine = dict(recorded.machine)
    items = [
        f"**Code:** commit {recorded.commit}{dirty[recorded.dirty]}. Races ran at {commits}.",
        f"**Races:** {len(tournament.races)}, {c.get('races_per_pair')} per pair and track; laps: {laps}; time limit "
        f"{c.get('time_limit')} s.",
        f"**Starts:** the pair's first agent in lane {lanes.get('even_races', ['?'])[0]} in even races, lane "
        f"{lanes.get('odd_races', ['?'])[0]} in odd ones; conditions {_conditions(c)}; seed "
        f"{c.get('seed')} (a race's seed: `{c.get('race_seeds')}`).",
        f"**Plans:** applied {c.get('plan_latency')} s after they are asked for. Δr and Δv of agents without a "
        f"planner ({planned}) are measured against an MCTS planner in the background with "
        f"`{settings_of}`'s settings ({json.dumps(background)}).",
        f"**Kart:** preset `{recorded.kart_preset}` (its values in `manifest.json`).",
        f"**Machine:** Python {machine.get('python')}, {machine.get('platform')}, {machine.get('cpus')} CPUs.",
    ]
    return [_wrap(f"- {item}", "  ") for item in items]


def results_readme(stats: TournamentStats, tournament: Tournament, race_commits: Mapping[str, int]) -> str:
    """The published folder's ``README.md``: what was run (code, agents with every parameter, conditions,
    machine) and the tables."""
    recorded = tournament.manifest
    assert recorded is not None
    lines = [
        f"# Results: tournament `{tournament.id}`",
        "",
        _wrap(
            f"Written by `karting tournament publish {tournament.id}` from the stored tournament; not edited by "
            "hand. `tests/test_stale_results.py` fails when the agents below no longer resolve to the same "
            "parameters and weights in the registry, or when a file here differs from `manifest.json`."
        ),
        "",
        "## What was run",
        "",
        f"    {run_command(tournament.id, tournament.spec)}",
        "",
        *_what_was_run(tournament, race_commits),
        "",
        "## Agents (every public parameter)",
        "",
        "| agent | parameters | weights (sha256) |",
        "|---|---|---|",
    ]
    for agent in recorded.agents:
        parameters = ", ".join(f"{k}={json.dumps(v)}" for k, v in agent.parameters.items()) or "none"
        weights = f"`{agent.weights['path']}` {agent.weights['sha256'][:12]}" if agent.weights else "-"
        lines.append(f"| `{agent.agent}` | {parameters} | {weights} |")
    for track, table in stats.tracks.items():
        if track == COMBINED and len(stats.tracks) == 2:
            continue  # one track: the same table again
        name = "all tracks" if track == COMBINED else f"`{track}`"
        lines += ["", f"## Wins on {name} (row agent against column agent)", "", markdown_table(totals_rows(table))]
    combined = stats.tracks[COMBINED]
    lines += ["", "## Safety per race over all tracks: mean and std. dev.", "", markdown_table(safety_rows(combined))]
    lines += ["", "`report.md` has every table per track (plan following, start lanes), `*.csv` the same, `*.png`"]
    lines += ["the plots, `stats.json` the statistics and their tests; `*`: significant at p = 0.05.", ""]
    return "\n".join(lines)


def sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def publish(tournament: Tournament, out: Path, readme: Path | None, lookup: SpecLookup = controller_spec) -> list[Path]:
    """Write ``tournament``'s results into ``out`` and its table into ``readme`` (``None``: leave the README);
    returns the files written. :class:`PublishError` (before anything is written) when it cannot be published,
    the README lacks the markers, or ``out`` holds files that no earlier publication wrote (besides a
    ``README.md`` without figures, which it writes over)."""
    problems = publish_problems(tournament, lookup)
    readme_text = readme.read_text() if readme is not None else None
    if readme is not None and readme_block(readme_text or "") is None:
        problems.append(f"{readme} has no {BEGIN} ... {END} block: add the markers where the table goes")
    earlier: dict[str, str] = {}
    if (out / MANIFEST_FILE).is_file():
        earlier = json.loads((out / MANIFEST_FILE).read_text()).get("files", {})
    if out.is_dir():
        kept = set(earlier) | {MANIFEST_FILE}
        foreign = [name for name in _files(out) if name not in kept and not _tableless(out, name)]
        if foreign:
            problems.append(f"{out} holds files no publication wrote: {foreign}; remove them (git rm) first")
    if problems:
        raise PublishError("\n".join(problems))
    for name in earlier:  # the last publication's files: some may not be written again (another track)
        (out / name).unlink(missing_ok=True)
    stats = tournament_stats(tournament.races)
    title = f"Tournament {tournament.id} ({len(tournament.races)} races)"
    written = write_report(stats, tournament.races, out, title)
    race_commits: dict[str, int] = {}
    for race_manifest in tournament.race_manifests:
        if race_manifest is not None:
            race_commits[race_manifest.commit] = race_commits.get(race_manifest.commit, 0) + 1
    folder = os.path.relpath(out, readme.parent) if readme is not None else str(out)
    table = readme_table(stats, tournament, folder)
    (out / README_FILE).write_text(results_readme(stats, tournament, race_commits))
    (out / README_TABLE_FILE).write_text(table + "\n")
    written += [out / README_FILE, out / README_TABLE_FILE]
    assert tournament.manifest is not None
    published_at, published_dirty = source_commit()
    data = {
        **tournament.manifest.to_json(),
        "tournament": {"id": tournament.id, "spec": dict(tournament.spec), "races": len(tournament.races)},
        "race_commits": race_commits,
        "published_at_commit": published_at,
        "published_dirty": published_dirty,
        "files": {str(p.relative_to(out)): sha256(p) for p in sorted(written)},
    }
    (out / MANIFEST_FILE).write_text(json.dumps(data, indent=1) + "\n")
    written.append(out / MANIFEST_FILE)
    if readme is not None and readme_text is not None:
        readme.write_text(replace_block(readme_text, table))
    return written


def published_problems(folder: Path, readme: Path | None, lookup: SpecLookup = controller_spec) -> list[str]:
    """What is wrong with the results published in ``folder`` (and the table in ``readme``'s block), checked
    against the registry now (empty: nothing). Without a ``manifest.json`` the folder may hold no file but a
    ``README.md`` without a table, and the README's block no table; with one, every file in the folder is one
    it lists, unchanged, its agents resolve as they did (:func:`arena.manifest.stale_agents`) and the README's
    block is its ``readme_table.md``."""
    files = _files(folder) if folder.is_dir() else []
    block = readme_block(readme.read_text()) if readme is not None and readme.is_file() else None
    path = folder / MANIFEST_FILE
    if not path.is_file():
        problems = [f"{folder / name}: a table without a manifest" for name in files if not _tableless(folder, name)]
        if block is not None and _has_table(block):
            problems.append(f"{readme}: a results table between the markers, and no {path}")
        return problems
    data = json.loads(path.read_text())
    listed: Mapping[str, str] = data.get("files", {})
    problems = [f"{folder / name}: not in {path}" for name in files if name not in listed and name != MANIFEST_FILE]
    for name, digest in listed.items():
        if not (folder / name).is_file():
            problems.append(f"{folder / name}: listed in {path} but missing")
        elif sha256(folder / name) != digest:
            problems.append(f"{folder / name}: changed since it was published")
    problems += [f"stale: {p}" for p in stale_agents(Manifest.from_json(data), lookup)]
    if readme is not None:
        table = folder / README_TABLE_FILE
        expected = table.read_text().strip() if table.is_file() else None
        if block is None:
            problems.append(f"{readme}: no {BEGIN} ... {END} block for the results table")
        elif block != expected:
            problems.append(f"{readme}: the table between the markers is not {table}")
    return problems


def _has_table(text: str) -> bool:
    """Whether ``text`` has a Markdown table with figures: a row with a cell past the first that starts with a
    digit (a table's empty outline is no result)."""
    rows = [line.strip().strip("|").split("|") for line in text.splitlines() if line.lstrip().startswith("|")]
    return any(re.match(r"\s*[0-9]", cell) for row in rows for cell in row[1:])


def _tableless(folder: Path, name: str) -> bool:
    """A ``README.md`` without a table of figures (what the folder may say before anything is published; a
    publication writes over it)."""
    return name == README_FILE and not _has_table((folder / name).read_text())
