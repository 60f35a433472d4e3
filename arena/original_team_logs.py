"""A reader for the original implementation's team (2v2) race logs, and the figures its own parser gives them,
with the defects of the data stated (``../shared/spec/teams.md``; the logs are in
``../shared/spec/original_logs_teams/``, never in this repository).

Format: one file per pairing and track, ``A_vs_B_OvalDuos.txt`` (the first collection) or ``…Duos2.txt`` (the
re-collection, where there is one: the original's parser takes it), 48 races each. A race block is ``Experiment
k`` and ten ``TYPE(i) Field: value`` lines per kart, four karts in the order of the original's ``Agents`` array;
the type is the team. Start slots are not logged: race k puts the karts in the order of permutation ``k mod 24``
(lexicographic) of that array into slots 0-3: lanes 2 and 3 of checkpoint 0, then lanes 2 and 3 of checkpoint 1,
one checkpoint nearer the flag (the front row).

Scoring is :mod:`arena.teams` with the original's points. The defects found are reported, not corrected, except
that :attr:`TeamLogs.genuine` leaves out the races of a file that copies another track's file.
"""

from __future__ import annotations

import hashlib
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from itertools import permutations
from pathlib import Path

from arena.original_logs import AGENT_NAMES, TRACK_NAMES, LogFormatError, race_blocks
from arena.records import CHECKPOINT, KartFigures, RaceFigures
from arena.teams import team_figures, team_result

KARTS = 4
SLOT_LANES = (2, 3, 2, 3)  # the lane of slots 0-3
FRONT_ROW = frozenset({2, 3})  # slots one checkpoint ahead
TIME_LIMIT = 120.0  # [s] the original's episode length (its DNFs log this, or an earlier deactivation)
TAKEN_OUT = 1.0  # [s] a non-finisher logged this long before the limit was taken out of the race

_FILE = re.compile(r"^(?P<a>[A-Za-z0-9_]+)_vs_(?P<b>[A-Za-z0-9_]+)_(?P<track>Oval|Complex)Duos(?P<run>\d*)\.txt$")
_FIELD = re.compile(r"^(?P<type>[A-Za-z0-9-]+)\((?P<member>\d+)\) (?P<field>[A-Za-z ]+?):\s*(?P<value>.*)$")


@dataclass(frozen=True)
class TeamLogFile:
    """One team log file: its pairing (registry names), track, collection (1: ``Duos``, 2: ``Duos2``), digest."""

    path: Path
    teams: tuple[str, str]
    track: str
    run: int
    digest: str  # SHA-256 of the file's bytes


def grid_slots(experiment: int) -> tuple[int, ...]:
    """The start slot of each kart (in log order) in race ``experiment``."""
    order = list(permutations(range(KARTS)))[experiment % 24]
    slots = [0] * KARTS
    for slot, kart in enumerate(order):
        slots[kart] = slot
    return tuple(slots)


def team_log_files(folder: str | Path) -> list[TeamLogFile]:
    """The files the original's parser reads: per pairing and track the re-collection where there is one."""
    found: dict[tuple[str, str, str], TeamLogFile] = {}
    for path in sorted(Path(folder).glob("*.txt")):
        match = _FILE.match(path.name)
        if match is None:
            continue
        teams = tuple(AGENT_NAMES.get(match[side].replace("_", "-"), "") for side in ("a", "b"))
        if not all(teams):
            raise LogFormatError(f"{path.name}: unknown agent in the file name; known: {sorted(AGENT_NAMES)}")
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        log = TeamLogFile(path, (teams[0], teams[1]), TRACK_NAMES[match["track"]], int(match["run"] or 1), digest)
        key = (*log.teams, log.track)
        if key not in found or found[key].run < log.run:
            found[key] = log
    if not found:
        raise FileNotFoundError(f"no team race logs (A_vs_B_TrackDuosN.txt) in {folder}")
    return sorted(found.values(), key=lambda log: (list(TRACK_NAMES.values()).index(log.track), log.path.name))


def read_team_log(log: TeamLogFile) -> list[RaceFigures]:
    """Every race of one file, in file order; ``extra`` holds the file, the karts' slots, laps completed of the
    race's laps, and the logged time of every kart (a non-finisher's: the limit, or when it was taken out)."""
    races = []
    for experiment, line, lines in race_blocks(log.path):
        karts: dict[str, dict[str, str]] = {}
        for number, text in lines:
            if text.startswith("Winner:"):  # empty, or wrong where filled: not read
                continue
            match = _FIELD.match(text)
            if match is None or match["type"] not in AGENT_NAMES:
                raise LogFormatError(f"{log.path.name}:{number}: not 'TYPE(i) Field: value' of a known type: {text!r}")
            karts.setdefault(f"{match['type']}({match['member']})", {})[match["field"]] = match["value"]
        try:
            names = list(karts)
            laps = [tuple(int(x) for x in karts[n]["Laps Completed"].split("/")) for n in names]
            times = [float(karts[n]["Total Time"]) for n in names]
            figures = tuple(
                KartFigures(
                    agent=AGENT_NAMES[name.split("(")[0]],
                    finished=done == total,
                    total_time=time if done == total else None,
                    collisions_at_fault=int(karts[name]["Collisions"]),
                    illegal_lane_changes={CHECKPOINT: int(karts[name]["Illegal Lane Changes"])},
                    safety_rule=CHECKPOINT,
                    delta_r=float(karts[name]["Avg Target Lane Difference"]),
                    delta_v=float(karts[name]["Avg Target Vel Difference"]),
                )
                for name, (done, total), time in zip(names, laps, times, strict=True)
            )
        except (KeyError, ValueError) as exc:
            raise LogFormatError(f"{log.path.name}:{line}: missing or malformed field ({exc})") from None
        teams = tuple(k.agent for k in figures)
        if len(figures) != KARTS or sorted(set(teams)) != sorted(log.teams):
            raise LogFormatError(f"{log.path.name}:{line}: karts {names}, expected two of each of {log.teams}")
        slots = grid_slots(experiment)
        races.append(
            RaceFigures(
                track=log.track,
                karts=figures,
                index=experiment,
                start_lanes=tuple(SLOT_LANES[s] for s in slots),
                teams=teams,
                extra={"file": log.path.name, "slots": slots, "laps": laps, "times": times},
            )
        )
    return races


@dataclass(frozen=True)
class TeamLogs:
    """The team logs the original's parser reads, with what is wrong with them."""

    files: tuple[TeamLogFile, ...]
    races: tuple[RaceFigures, ...]  # every race of every file, as the parser counts them
    copies: Mapping[str, str] = field(default_factory=dict)  # file -> the file of another track it copies

    @cached_property
    def genuine(self) -> tuple[RaceFigures, ...]:
        """The races without those of copied files."""
        return tuple(race for race in self.races if race.extra["file"] not in self.copies)

    def defects(self) -> list[str]:
        """The data's defects, each a sentence with its figures (on the genuine races)."""
        found = [f"{copy} is a byte copy of {original}" for copy, original in self.copies.items()]
        results = [(race, team_result(race)) for race in self.genuine]
        for track in TRACK_NAMES.values():
            on_track = [(race, result) for race, result in results if race.track == track]
            winners = [race.extra["slots"][result.order[0]] for race, result in on_track if result.order]  # type: ignore[index]
            front = sum(slot in FRONT_ROW for slot in winners)
            held = [(race, result) for race, result in on_track if _front_row_team(race) is not None]
            held_won = sum(result.winner == _front_row_team(race) for race, result in held)
            found.append(
                f"{track}: the winner started on the front row (one checkpoint nearer the flag) in {front} of "
                f"{len(winners)} races; a team with both karts in front won {held_won} of {len(held)}"
            )
        ties = sum(result.tied for _, result in results)
        split = [
            race
            for race, result in results
            if result.points_winner is not None and result.points_winner != result.winner
        ]
        split_finished = sum(all(kart.finished for kart in race.karts) for race in split)
        taken_out = sum(
            not kart.finished and time < TIME_LIMIT - TAKEN_OUT
            for race, _ in results
            for kart, time in zip(race.karts, race.extra["times"], strict=True)  # type: ignore[call-overload]
        )
        found.append(f"{ties} races have finishers with equal times (placed in log order, as the parser does)")
        found.append(
            f"{len(split)} races are won by one team and scored higher for the other ({split_finished} of them with "
            "every kart finished)"
        )
        found.append(
            f"{taken_out} unfinished karts were taken out before the {TIME_LIMIT:.0f} s limit (cause not logged)"
        )
        return found


def _front_row_team(race: RaceFigures) -> str | None:
    """The team with both karts on the front row, if one has."""
    teams = race.teams or ()
    front = [team for team, slot in zip(teams, race.extra["slots"], strict=True) if slot in FRONT_ROW]  # type: ignore[call-overload]
    return front[0] if len(front) == 2 and front[0] == front[1] else None


def _copies(files: Sequence[TeamLogFile], races: Mapping[str, list[RaceFigures]]) -> dict[str, str]:
    """Files whose bytes equal another track's file: the copy is the one whose races have the other track's laps
    (the laps most races of its own track have)."""
    track_laps: dict[str, Counter[int]] = {}
    for log in files:
        for race in races[log.path.name]:
            track_laps.setdefault(log.track, Counter()).update(total for _, total in race.extra["laps"])  # type: ignore[attr-defined]
    copies = {}
    for log in files:
        for other in files:
            if other is log or other.digest != log.digest or other.track == log.track:
                continue
            laps = races[log.path.name][0].extra["laps"][0][1]  # type: ignore[index]
            if laps != track_laps[log.track].most_common(1)[0][0]:
                copies[log.path.name] = other.path.name
    return copies


def read_original_team_logs(folder: str | Path) -> TeamLogs:
    """The team logs of ``folder`` as the original's parser reads them, with their defects."""
    files = team_log_files(folder)
    races = {log.path.name: read_team_log(log) for log in files}
    return TeamLogs(tuple(files), tuple(race for log in files for race in races[log.path.name]), _copies(files, races))


COMBINED = "combined"


def _by_track(races: Sequence[RaceFigures]) -> dict[str, dict[str, dict[str, object]]]:
    """Per track and both together: every team's figures (:func:`arena.teams.team_figures`) as JSON."""
    tables = {}
    for track in (*TRACK_NAMES.values(), COMBINED):
        chosen = [race for race in races if track in (COMBINED, race.track)]
        tables[track] = {team: figures.to_json() for team, figures in sorted(team_figures(chosen).items())}
    return tables


def team_logs_report(logs: TeamLogs) -> dict[str, object]:
    """The figures of the original's team logs as JSON: ``parser`` (every file, the copied one included, as the
    original's parser counts), ``genuine`` (without copies), per-pairing ``matchups`` (genuine files), ``defects``
    and the ``files`` read."""
    matchups = []
    for log in logs.files:
        if log.path.name in logs.copies:
            continue
        races = [race for race in logs.genuine if race.extra["file"] == log.path.name]
        figures = team_figures(races)
        points_wins = Counter(team_result(race).points_winner for race in races)
        matchups.append(
            {
                "track": log.track,
                "teams": list(log.teams),
                "file": log.path.name,
                "races": len(races),
                "points_wins": [points_wins[team] for team in log.teams],
                "figures": [figures[team].to_json() for team in log.teams],
            }
        )
    return {
        "parser": _by_track(logs.races),
        "genuine": _by_track(logs.genuine),
        "matchups": matchups,
        "defects": logs.defects(),
        "files": [{"file": log.path.name, "collection": log.run, "sha256": log.digest} for log in logs.files],
    }
