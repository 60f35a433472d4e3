"""The original's team experiment, reproduced and made fair (``karting reproduce teams``): the five agents as 2v2
teams of one agent each, a round robin on ``oval`` and ``complex`` under ``varied`` conditions, on a one-row
grid in mirrored pairs of races (:meth:`arena.tournament.TournamentSpec.team_race`).

The tournament is published into ``OUT/tournament/`` (:func:`arena.publish.publish`: tables, plots, the
manifest); :func:`team_findings` writes ``OUT/README.md``: each agent's team figures beside the original's (read
from its logs, :mod:`arena.original_team_logs`, when they are at hand) and every pair's, each with its interval.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from arena.original_team_logs import read_original_team_logs
from arena.publish import Tournament
from arena.records import RaceFigures
from arena.reproduce import PAPER_AGENTS, rate_text
from arena.stats import COMBINED, tournament_stats
from arena.teams import HOLD_GAP, TeamFigures, team_figures
from arena.tournament import TournamentSpec

TRACKS = ("oval", "complex")
DEFAULT_TEAM_RACES = 20  # per pair and track: ten mirrored pairs
TOURNAMENT_FOLDER = "tournament"


def team_spec(races_per_pair: int, seed: int = 0) -> TournamentSpec:
    """The team round robin: the paper's agents, two karts each, ``races_per_pair`` (even) races per pair and
    track under ``varied`` conditions."""
    return TournamentSpec(PAPER_AGENTS, TRACKS, races_per_pair, seed, conditions="varied", team_size=2).validate()


def team_tournament_id(races_per_pair: int, seed: int = 0) -> str:
    """The stored tournament of a team reproduction of this size and seed."""
    return f"teams-varied-{races_per_pair}-s{seed}"


def _rate(figures: TeamFigures | None) -> str:
    return "-" if figures is None else rate_text(figures.wins, figures.races)


def _safety(figures: TeamFigures | None) -> str:
    if figures is None:
        return "-"
    ci = figures.safety_ci95
    return f"{figures.safety:.2f}" + ("" if ci is None else f" [{ci.low:.2f}, {ci.high:.2f}]")


def _teammate(figures: TeamFigures | None) -> str:
    per_race = None if figures is None else figures.teammate_contacts_per_race
    return "-" if per_race is None else f"{per_race:.2f}"


def _teammate_passes(figures: TeamFigures | None) -> str:
    if figures is None or figures.races_with_teammate_pass is None:
        return "-"
    return rate_text(figures.races_with_teammate_pass, figures.races)


def _rival_held(figures: TeamFigures | None) -> str:
    return "-" if figures is None else rate_text(figures.races_with_rival_held, figures.races)


def _per_track(races: Sequence[RaceFigures]) -> dict[str, dict[str, TeamFigures]]:
    return {track: team_figures([r for r in races if track in (COMBINED, r.track)]) for track in (*TRACKS, COMBINED)}


def team_findings(tournament: Tournament, original_logs: Path | None) -> str:
    """The reproduction's README: what was run, each agent's team figures beside the original's, and each pair."""
    ours = _per_track(tournament.races)
    original: Mapping[str, Mapping[str, TeamFigures]] = {}
    source = "not at hand (run with --original-logs to add them)"
    if original_logs is not None and original_logs.is_dir():
        logs = read_original_team_logs(original_logs)
        original = _per_track(logs.genuine)
        source = (
            f"the original's logs, read by `arena/original_team_logs.py` without the copied file "
            f"({len(logs.genuine)} races)"
        )
    spec = tournament.spec
    lines = [
        "# The original's team experiment, reproduced on a fair grid",
        "",
        f"Written by `karting reproduce teams` (tournament `{tournament.id}`, "
        f"{len(tournament.races)} races; tables, plots and manifest in [`{TOURNAMENT_FOLDER}/`]"
        f"({TOURNAMENT_FOLDER}/README.md)). The five agents as 2v2 teams of one agent, every pair "
        f"{spec['races_per_pair']} races per track on `oval` and `complex` under `{spec['conditions']}` conditions: "
        "four karts side by side on one row (every kart the same distance to the flag; the original put one team a "
        "checkpoint ahead), races in mirrored pairs (the same seed, the teams' slots swapped). Scored as the "
        "original's parser scored its races: the fastest finisher's team wins, places pay 10 / 7.5 / 6 / 4. "
        "The agents plan for their team (the tactical game's team objective); the RL agents were trained for one "
        "opponent and observe the nearest karts. 95% intervals: Wilson for win rates, bootstrap for means.",
        "",
        "Cooperation: contacts between a team's own karts per race; the races in which one of its karts "
        "passed the other (the referee's passes: a place taken and held for 2 s), a team-mate let by or a faster "
        "team-mate through; and the races in which one of its karts held a rival for its team-mate at the flag: "
        f"it finished directly behind its team-mate and directly ahead of a rival at most {HOLD_GAP:g} s behind it "
        "(a rival on its tail that did not get by; `arena.teams.rival_held`). The last is read from the finishing "
        "order and times, not from the race as it ran; the original's logs give it too (its logs record no "
        "contacts or passes by pair), though its head-start grid made one team's 1-2 finish more likely.",
        "",
        f"The original's figures: {source}. Its grid gave the front row a checkpoint's head start, so its win "
        "rates are not comparable one for one.",
        "",
    ]
    for track in (*TRACKS, COMBINED):
        lines += [
            f"## {track}: each agent's team",
            "",
            "| team | wins, ours | wins, original | team points, ours | safety per kart-race, ours | "
            "safety, original | unfinished karts, ours | team-mate contacts per race, ours | "
            "races with a pass between team-mates, ours | races with a rival held for a team-mate, ours | "
            "rival held, original |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        for agent in PAPER_AGENTS:
            mine, theirs = ours[track].get(agent), original.get(track, {}).get(agent)
            points = "-" if mine is None else f"{mine.mean_points:.2f}"
            unfinished = "-" if mine is None else str(mine.unfinished)
            lines.append(
                f"| {agent} | {_rate(mine)} | {_rate(theirs)} | {points} | {_safety(mine)} | {_safety(theirs)} | "
                f"{unfinished} | {_teammate(mine)} | {_teammate_passes(mine)} | {_rival_held(mine)} | "
                f"{_rival_held(theirs)} |"
            )
        lines.append("")
    lines += [
        "## Every pair (both tracks)",
        "",
        "| first team vs second | first's wins | mean points | safety per kart-race | mirrored pairs split |",
        "|---|---|---|---|---|",
    ]
    stats = tournament_stats(tournament.races).tracks[COMBINED]
    for pair in stats.team_pairs.values():
        a, b = pair.first, pair.second
        lines.append(
            f"| {a.team} vs {b.team} | {_rate(a)} | {a.mean_points:.2f} / {b.mean_points:.2f} | "
            f"{a.safety:.2f} / {b.safety:.2f} | {pair.split_pairs} of {pair.mirrored_pairs} |"
        )
    lines += [
        "",
        "A mirrored pair is split when each team won one of its two races: the grid slot, not the team, decided.",
        "",
    ]
    return "\n".join(lines)
