"""The paper's experiment, reproduced with today's registered agents (``karting reproduce paper``): its round robin
of the five agents on ``oval`` and ``complex`` under both condition sets (:mod:`sim_core.conditions`): ``paper``
(the original's: simultaneous launch, lanes 2 and 3 alternating, no imprecision) and ``varied``.

Each set's tournament is published into its own folder (:func:`arena.publish.publish`: tables with intervals,
plots, the manifest); :func:`findings` puts the paper's headline figures beside ours, each with its interval,
into the results folder's ``README.md`` and the project README's results block (``readme_table.md``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from arena.intervals import wilson
from arena.publish import (
    MANIFEST_FILE,
    README_TABLE_FILE,
    Tournament,
    published_problems,
    readme_block,
    replace_block,
)
from arena.report import markdown_table
from arena.stats import COMBINED, TournamentStats, tournament_stats
from arena.tournament import TournamentSpec
from sim_core.conditions import ConditionSet, condition_set

PAPER_AGENTS = ("mcts-rl", "e2e", "fixed-rl", "mcts-lqng", "fixed-lqng")
CONDITIONS = ("paper", "varied")
DEFAULT_RACES = {"paper": 50, "varied": 100}  # per pair and track
# the paper's headline figures (its oval and complex win tables added up): wins of the first agent against the
# second in 100 races (50 per track), and MCTS-RL's wins of its 400 races
PAPER_WINS = {
    ("mcts-rl", "fixed-rl"): 96,
    ("mcts-lqng", "fixed-lqng"): 53,
    ("mcts-rl", "e2e"): 97,
    ("mcts-rl", "mcts-lqng"): 79,
}
PAPER_MCTS_RL_WINS = (363, 400)
HEADLINE_WIN_RATE = 0.85  # the paper: MCTS-RL wins at least this share of its races


@dataclass(frozen=True)
class Reproduction:
    """One condition set's tournament and what it measured."""

    conditions: str
    tournament: Tournament
    stats: TournamentStats

    @property
    def spec(self) -> Mapping[str, object]:
        """The tournament's spec, as stored."""
        return self.tournament.spec


def reproduction_spec(conditions: str, races_per_pair: int, seed: int = 0) -> TournamentSpec:
    """The paper's round robin under ``conditions`` with ``races_per_pair`` races per pair and track."""
    return TournamentSpec(PAPER_AGENTS, ("oval", "complex"), races_per_pair, seed, conditions=conditions).validate()


def tournament_id(conditions: str, races_per_pair: int, seed: int = 0) -> str:
    """The stored tournament of a condition set's reproduction (one per size and seed: each resumes alone)."""
    return f"paper-{conditions}-{races_per_pair}-s{seed}"


def rate_text(wins: int, races: int) -> str:
    """``wins/races = x% [low, high]`` with the 95% Wilson interval (``-`` without races)."""
    interval = wilson(wins, races)
    if interval is None:
        return "-"
    return f"{wins}/{races} = {100 * wins / races:.0f}% [{100 * interval.low:.0f}, {100 * interval.high:.0f}]"


def overall_wins(stats: TournamentStats, agent: str) -> tuple[int, int]:
    """(races ``agent`` won, races it ran), over every track."""
    table = stats.tracks[COMBINED]
    return sum(table.wins[agent].values()), table.agent_stats[agent].races


def findings_rows(reproductions: Sequence[Reproduction]) -> list[list[str]]:
    """The paper's headline figures beside ours under each condition set, with 95% Wilson intervals."""
    header = ["finding", "paper", *(f"ours, `{r.conditions}` conditions" for r in reproductions)]
    rows = [header]
    cells = ["MCTS-RL's share of its races won", rate_text(*PAPER_MCTS_RL_WINS)]
    for r in reproductions:
        cells.append(rate_text(*overall_wins(r.stats, "mcts-rl")))
    rows.append(cells)
    for (a, b), paper_wins in PAPER_WINS.items():
        cells = [f"{a} against {b}", rate_text(paper_wins, 100)]
        for r in reproductions:
            table = r.stats.tracks[COMBINED]
            pair = table.pairs.get(frozenset((a, b)))
            cells.append(rate_text(table.wins[a][b], pair.races) if pair else "-")
        rows.append(cells)
    cells = ["pairs whose every race the start lane decided", "-"]
    for r in reproductions:
        decided = lane_decided_pairs(r.stats)
        cells.append(", ".join(decided) if decided else "none")
    rows.append(cells)
    rows.append(["ratings (Plackett-Luce θ, best first)", "-", *(_ratings(r.stats) for r in reproductions)])
    return rows


def _ratings(stats: TournamentStats) -> str:
    return "; ".join(
        f"{r.agent} {r.theta:.2f}" + (f" [{r.ci95.low:.2f}, {r.ci95.high:.2f}]" if r.ci95 else "")
        for r in stats.ratings
    )


def lane_decided_pairs(stats: TournamentStats) -> list[str]:
    """Pairs (per track) whose every race was won from the same start lane, unless one agent won them all."""
    found = []
    for track, table in stats.tracks.items():
        if track == COMBINED:
            continue
        for (a, b), split in table.start_lanes.pairs.items():
            if table.agents.index(a) > table.agents.index(b):
                continue
            records = list(split.by_lane.values())
            swept = sum(r.wins for r in records) in (0, sum(r.races for r in records))
            lane_won = all(r.wins == r.races for r in records[:1]) and all(r.wins == 0 for r in records[1:])
            lane_lost = all(r.wins == 0 for r in records[:1]) and all(r.wins == r.races for r in records[1:])
            if (lane_won or lane_lost) and not swept:
                found.append(f"{a} vs {b} on `{track}`")
    return found


def findings(reproductions: Sequence[Reproduction]) -> str:
    """The results folder's ``README.md``: what was run and the findings table."""
    runs = [
        f"- `{r.conditions}`: {r.spec['races_per_pair']} races per pair and track, tournament "
        f"`{r.tournament.id}`, commit {r.tournament.manifest.commit[:10] if r.tournament.manifest else '?'}; "
        f"tables, plots and manifest in [`{r.conditions}/`]({r.conditions}/README.md)"
        for r in reproductions
    ]
    return "\n".join(
        [
            "# The paper's experiment, reproduced",
            "",
            "Written by `karting reproduce paper` (the command regenerates every file here). The paper's round robin",
            "of its five agents on `oval` and `complex`, with today's registered agents, under both sets of race",
            "conditions (`docs/conditions.md`):",
            "",
            *runs,
            "",
            readme_table(reproductions),
            "",
        ]
    )


def readme_table(reproductions: Sequence[Reproduction]) -> str:
    """The project README's results block: the findings with their intervals."""
    sizes = ", ".join(f"`{r.conditions}` {r.spec['races_per_pair']}" for r in reproductions)
    return (
        f"The paper's headline figures beside ours (races per pair and track: {sizes}; 95% Wilson intervals in "
        "brackets; written by `karting reproduce paper`, details in [`docs/results/`](docs/results/README.md)).\n\n"
        + markdown_table(findings_rows(reproductions))
    )


def write_findings(reproductions: Sequence[Reproduction], out: Path, readme: Path | None) -> list[Path]:
    """Write the results folder's README and table, and the table into ``readme``'s results block."""
    table = readme_table(reproductions)
    (out / "README.md").write_text(findings(reproductions))
    (out / README_TABLE_FILE).write_text(table + "\n")
    if readme is not None:
        text = readme.read_text()
        if readme_block(text) is not None:
            readme.write_text(replace_block(text, table))
    return [out / "README.md", out / README_TABLE_FILE]


def reproduction_problems(out: Path, readme: Path | None) -> list[str]:
    """What is wrong with the reproduction published in ``out`` against the registry now (empty: nothing): each
    condition set's folder as :func:`arena.publish.published_problems` checks it, and the README's results block
    is the findings table written with them."""
    problems = []
    for conditions in CONDITIONS:
        problems += [f"{conditions}/: {p}" for p in published_problems(out / conditions, None)]
        problems += [f"{conditions}/: {p}" for p in stale_conditions(out / conditions, conditions)]
    table = out / README_TABLE_FILE
    if not table.is_file():
        problems.append(f"{table} is missing: run karting reproduce paper")
    elif readme is not None and readme_block(readme.read_text()) != table.read_text().strip():
        problems.append(f"{readme}'s results block is not {table}")
    return problems


def stale_conditions(folder: Path, conditions: str) -> list[str]:
    """How the condition set a published tournament raced under differs from the set of that name now (empty:
    it does not, or nothing is published there): results raced under another ``varied`` are not ``varied``'s. A
    parameter missing from the record counts as its default (sets gain parameters whose default changes nothing)."""
    manifest = folder / MANIFEST_FILE
    if not manifest.is_file():
        return []
    recorded = json.loads(manifest.read_text()).get("conditions", {}).get("conditions")
    now = condition_set(conditions).to_json()
    if not isinstance(recorded, dict):
        return [f"its manifest records no {conditions!r} condition set: run karting reproduce paper"]
    # a parameter the sets gained since, at its default, draws what the set drew before it existed
    defaults = ConditionSet("defaults").to_json()
    changed = sorted(
        key
        for key in set(recorded) | set(now)
        if (recorded[key] if key in recorded else defaults.get(key)) != now.get(key)
    )
    return (
        [f"the {conditions!r} conditions changed since it raced ({', '.join(changed)}): run it again"]
        if changed
        else []
    )


def reproduction_of(conditions: str, tournament: Tournament) -> Reproduction:
    """A published tournament as one condition set's reproduction."""
    return Reproduction(conditions, tournament, tournament_stats(tournament.races))
