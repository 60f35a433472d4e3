"""A reader for the original implementation's released race logs (``ExperimentLogs/`` of the authors' Unity
project; a copy lives in ``../shared/spec/original_logs/``, never in this repository).

Format: one file per pairing and track, ``A_vs_B_Oval2.txt`` / ``A_vs_B_Complex2.txt``, 50 races each. A block
per race: ``Experiment N``, then per agent ``NAME Field: value`` lines (``Total Time``, ``Laps Completed: k/n``,
``Illegal Lane Changes``, ``Collisions``, ``Avg Target Lane Difference`` = Δr, ``Avg Target Vel Difference`` =
Δv, ...). The ``Winner:`` line is empty in the data and is not read: the win rule is
:func:`arena.records.winner_index`. For MCTS-LQNG vs Fixed-LQNG on the complex track the paper used
``MCTS_LQR_vs_Fixed_LQR_Complex3.txt`` (a re-run); :data:`PREFERRED_RUNS` says so and the reader takes it.

Start lanes are not logged; they follow from the original's experiment grid (``RacingEnvController.ResetGame``):
race ``Experiment N`` places the karts in the order ``allOrderings[N % n!]`` (the permutations of its ``Agents``
array, in lexicographic order) into lanes 2, 3, 2, 3 at checkpoint 0. The log lists the karts in ``Agents`` order
(its ``TelemetryViewer`` iterates that array), so with two karts the first one listed starts in lane 2 in even
races and in lane 3 in odd ones (:func:`original_start_lanes`).

The original counts illegal lane changes by sampling lanes at checkpoints (our ``checkpoint`` rule) and logs
collisions at fault as ``Collisions``; it logs no passes.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from itertools import permutations
from pathlib import Path

from arena.records import CHECKPOINT, KartFigures, RaceFigures

# the original's agent names -> our registry names (the paper calls the LQ tracker "LQNG", the code "LQR")
AGENT_NAMES: Mapping[str, str] = {
    "MCTS-RL": "mcts-rl",
    "E2E": "e2e",
    "Fixed-RL": "fixed-rl",
    "MCTS-LQR": "mcts-lqng",
    "Fixed-LQR": "fixed-lqng",
}
TRACK_NAMES: Mapping[str, str] = {"Oval": "oval", "Complex": "complex"}
# (file stem without the run number, run) the paper took instead of the default run 2
PREFERRED_RUNS: Mapping[str, int] = {"MCTS_LQR_vs_Fixed_LQR_Complex": 3}
DEFAULT_RUN = 2
GRID_LANES = (2, 3, 2, 3)  # the original's ``expLaneChoices``: the lane of the first, second, ... kart placed

_FILE = re.compile(r"^(?P<a>[A-Za-z0-9_]+)_vs_(?P<b>[A-Za-z0-9_]+)_(?P<track>Oval|Complex)(?P<run>\d+)\.txt$")
_EXPERIMENT = re.compile(r"^Experiment\s+(\d+)\s*$")
_FIELD = re.compile(r"^(?P<agent>\S+) (?P<field>[A-Za-z ]+?):\s*(?P<value>.*)$")
_WINNER = re.compile(r"^Winner:")  # left empty by the original: not read


class LogFormatError(ValueError):
    """A log file that does not follow the format (names the file and line)."""


@dataclass(frozen=True)
class LogFile:
    """One log file: its pairing (registry names), track and run number."""

    path: Path
    agents: tuple[str, str]
    track: str
    run: int
    key: str  # the file name without its run number and suffix (``MCTS_LQR_vs_Fixed_LQR_Complex``)


def _agent(file_token: str) -> str:
    original = file_token.replace("_", "-")
    if original not in AGENT_NAMES:
        raise LogFormatError(f"unknown agent {original!r} in a file name; known: {sorted(AGENT_NAMES)}")
    return AGENT_NAMES[original]


def log_files(folder: str | Path) -> list[LogFile]:
    """The log files the paper used, one per pairing and track (the preferred run where there are several)."""
    found: dict[str, LogFile] = {}
    for path in sorted(Path(folder).glob("*.txt")):
        match = _FILE.match(path.name)
        if match is None:
            continue
        agents = (_agent(match["a"]), _agent(match["b"]))
        key = path.name[: match.start("run")]
        log = LogFile(path, agents, TRACK_NAMES[match["track"]], int(match["run"]), key)
        wanted = PREFERRED_RUNS.get(log.key, DEFAULT_RUN)
        current = found.get(log.key)
        # the wanted run; failing that, the highest run there is
        if current is None or (log.run == wanted) or (current.run != wanted and log.run > current.run):
            found[log.key] = log
    if not found:
        raise FileNotFoundError(f"no race logs (A_vs_B_TrackN.txt) in {folder}")
    return sorted(found.values(), key=lambda log: (list(TRACK_NAMES.values()).index(log.track), log.key))


def original_start_lanes(experiment: int, karts: int) -> tuple[int, ...]:
    """The start lane of each kart (in log order) in race ``experiment`` of the original's experiment grid."""
    if not 1 <= karts <= len(GRID_LANES):
        raise ValueError(f"the original's grid has {len(GRID_LANES)} places, not {karts}")
    orderings = list(permutations(range(karts)))
    lanes = [0] * karts
    for place, kart in enumerate(orderings[experiment % len(orderings)]):
        lanes[kart] = GRID_LANES[place]
    return tuple(lanes)


def race_blocks(path: Path) -> Iterator[tuple[int, int, list[tuple[int, str]]]]:
    """(experiment number, line number, the block's non-empty lines) per race of a log file (the 1v1 and the team
    logs share the layout)."""
    current: tuple[int, int] | None = None
    lines: list[tuple[int, str]] = []
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        match = _EXPERIMENT.match(line)
        if match is not None:
            if current is not None:
                yield current[0], current[1], lines
            current, lines = (int(match[1]), number), []
        elif line.strip():
            if current is None:
                raise LogFormatError(f"{path.name}:{number}: a field before the first 'Experiment N'")
            lines.append((number, line))
    if current is not None:
        yield current[0], current[1], lines


def _kart(path: Path, line: int, agent: str, fields: Mapping[str, str]) -> KartFigures:
    try:
        done, laps = (int(x) for x in fields["Laps Completed"].split("/"))
        finished = done == laps
        return KartFigures(
            agent=AGENT_NAMES[agent],
            finished=finished,
            total_time=float(fields["Total Time"]) if finished else None,
            collisions_at_fault=int(fields["Collisions"]),
            illegal_lane_changes={CHECKPOINT: int(fields["Illegal Lane Changes"])},
            safety_rule=CHECKPOINT,
            passes=None,
            delta_r=float(fields["Avg Target Lane Difference"]),
            delta_v=float(fields["Avg Target Vel Difference"]),
        )
    except (KeyError, ValueError) as exc:
        raise LogFormatError(f"{path.name}:{line}: {agent}: missing or malformed field ({exc})") from None


def read_log(log: LogFile) -> list[RaceFigures]:
    """Every race of one log file, in file order."""
    races = []
    for experiment, line, lines in race_blocks(log.path):
        per_agent: dict[str, dict[str, str]] = {}
        for number, text in lines:
            if _WINNER.match(text):
                continue
            match = _FIELD.match(text)
            if match is None:
                raise LogFormatError(f"{log.path.name}:{number}: not 'AGENT Field: value': {text!r}")
            if match["agent"] in AGENT_NAMES:
                per_agent.setdefault(match["agent"], {})[match["field"]] = match["value"]
            else:
                raise LogFormatError(f"{log.path.name}:{number}: unknown agent {match['agent']!r}")
        karts = tuple(_kart(log.path, line, agent, fields) for agent, fields in per_agent.items())
        if sorted(k.agent for k in karts) != sorted(log.agents):
            raise LogFormatError(f"{log.path.name}:{line}: agents {[k.agent for k in karts]}, expected {log.agents}")
        races.append(
            RaceFigures(
                track=log.track,
                karts=karts,
                index=experiment,
                start_lanes=original_start_lanes(experiment, len(karts)),
                extra={"file": log.path.name},
            )
        )
    return races


def read_original_logs(folder: str | Path) -> list[RaceFigures]:
    """Every race the paper's tables were computed from: the preferred run of each pairing and track."""
    return [race for log in log_files(folder) for race in read_log(log)]
