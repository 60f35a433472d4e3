"""Tactics measured directly: short scenarios from placed karts, many seeded attempts per cell, figures with
intervals (the passing contests of racing robotics: an overtaking success rate against a leader of a given pace,
and the pace at which passes stop succeeding).

A :class:`Scenario` is data (a JSON file: the shipped ones in ``scenarios/``, or a user's own):

* ``overtake``: the ego starts ``gap_m`` behind a leader, both rolling in the racing lane at the leader's line
  speed, on a straight or before a corner (``place``); the leader drives at each pace of ``paces``. Success: the
  ego passed (held the place 2 s, the referee's count) and is ahead at the end;
* ``defend``: the ego leads at each pace of ``paces`` with a full-pace attacker ``gap_m`` behind. Success: the
  ego is still ahead at the end (the place held).

A cell is (scenario, track, ego, opponent, pace); attempt ``i`` of every cell of a scenario on a track has the
same seed, so the same gap and conditions (a paired design across egos, opponents and paces).
"""

from __future__ import annotations

import json
import multiprocessing
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from arena.intervals import Interval, bootstrap_mean, wilson
from arena.tournament import start_method
from controllers.race import Placement, RaceOutcome, RaceSpec, batch_key, load_any_track, run_races
from controllers.racing_line import optimise_racing_line
from controllers.registry import PACE_SEPARATOR, validate_agent
from sim_core import state as st
from sim_core.conditions import CONDITION_SETS
from sim_core.params import DT, MIN_PACE, PAPER_KART
from sim_core.state import PASS_HOLD_STEPS
from sim_core.track import Track
from sim_core.world import World

SCENARIO_DIR = Path(__file__).resolve().parent.parent / "scenarios"
Kind = Literal["overtake", "defend"]
KINDS: tuple[Kind, ...] = ("overtake", "defend")
Place = Literal["straight", "corner"]
PLACES: tuple[Place, ...] = ("straight", "corner")
STRAIGHT_CURVATURE = 1.0 / 150.0  # [1/m] the centre line is straight where it turns more gently than this
STRAIGHT_ENTRY = 20.0  # [m] "straight": the leader this far into the track's longest straight
CORNER_BEFORE = 35.0  # [m] "corner": the leader this far before the end of the longest straight
ROLLING_FRACTION = 0.9  # of the leader's line speed there: both karts roll in at this speed


@dataclass(frozen=True)
class Scenario:
    """One tactical situation, raced from placed karts (see the module notes)."""

    name: str
    kind: Kind
    description: str = ""
    tracks: tuple[str, ...] = ("oval", "complex")
    place: Place = "straight"
    gap_m: tuple[float, float] = (10.0, 20.0)  # [m] between the two karts, uniform per attempt
    paces: tuple[float, ...] = (0.90, 0.93, 0.95, 0.97, 0.99)  # overtake: the leader's; defend: the ego's
    laps: int = 3  # from the placement; a pass must be done within them
    conditions: str = "varied"

    def __post_init__(self) -> None:
        problems = self.problems()
        if problems:
            raise ValueError(f"scenario {self.name!r}: " + "; ".join(problems))

    def problems(self) -> list[str]:
        """What is wrong with it (empty: nothing)."""
        found = []
        if self.kind not in KINDS:
            found.append(f"kind must be one of {list(KINDS)}, got {self.kind!r}")
        if self.place not in PLACES:
            found.append(f"place must be one of {list(PLACES)}, got {self.place!r}")
        low, high = self.gap_m
        if not 2.5 <= low <= high <= 60.0:
            found.append(f"gap_m must be 2.5 <= low <= high <= 60 m, got {list(self.gap_m)}")
        if not self.paces or any(not MIN_PACE <= p <= 1.0 for p in self.paces):
            found.append(f"paces must be in [{MIN_PACE}, 1], got {list(self.paces)}")
        if not 1 <= self.laps <= 5:
            found.append(f"laps must be in 1..5, got {self.laps}")
        if self.conditions not in CONDITION_SETS:
            found.append(f"conditions must be one of {sorted(CONDITION_SETS)}, got {self.conditions!r}")
        if not self.tracks:
            found.append("tracks must name at least one track")
        return found

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Scenario:
        """A scenario from its file's object (``ValueError`` naming what is wrong)."""
        unknown = set(data) - {f for f in cls.__dataclass_fields__}
        if unknown:
            raise ValueError(f"scenario {data.get('name')!r}: unknown fields {sorted(unknown)}")
        values = dict(data)
        for name in ("tracks", "gap_m", "paces"):
            if name in values:
                values[name] = tuple(values[name])
        return cls(**values)

    def to_json(self) -> dict[str, Any]:
        """Every field, as its file holds it."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


def load_scenario(name_or_path: str) -> Scenario:
    """A shipped scenario by name, or a scenario file by path (``KeyError`` naming the shipped ones)."""
    path = Path(name_or_path)
    if not path.suffix:
        path = SCENARIO_DIR / f"{name_or_path}.json"
        if not path.is_file():
            raise KeyError(f"unknown scenario {name_or_path!r}; shipped: {shipped_scenarios()}")
    return Scenario.from_json(json.loads(path.read_text()))


def shipped_scenarios() -> list[str]:
    """Names of the scenarios in ``scenarios/``."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.json"))


@dataclass(frozen=True)
class Cell:
    """One cell of a scenario: the ego against the opponent on a track, the paced kart at ``pace``."""

    scenario: str
    track: str
    ego: str
    opponent: str
    pace: float

    def agents(self, kind: Kind) -> tuple[str, str]:
        """(ego, opponent) agent strings with the pace on the kart it handicaps."""
        if kind == "overtake":
            return self.ego, with_pace(self.opponent, self.pace)
        return with_pace(self.ego, self.pace), self.opponent


def with_pace(agent: str, pace: float) -> str:
    """``agent`` at ``pace`` (``agent`` itself at pace 1; ``ValueError`` if it already carries one)."""
    if PACE_SEPARATOR in agent:
        raise ValueError(f"agent {agent!r} carries its own pace: a scenario sets it")
    return agent if pace == 1.0 else f"{agent}{PACE_SEPARATOR}{pace:g}"


def longest_straight(track: Track) -> tuple[float, float]:
    """(start, end) [m] of centre-line progress of the track's longest straight (end may exceed the length when it
    runs over the line)."""
    straight = np.abs(track.centre_curvature) < STRAIGHT_CURVATURE
    if straight.all() or not straight.any():
        return 0.0, float(track.length)
    s = track.centre_s
    start = int(np.argmin(straight))  # a sample in a corner: runs are counted from there, wrapping once
    best, best_run, run_start = (0.0, 0.0), -1.0, None
    n = len(s)
    for step in range(1, n + 1):
        i = (start + step) % n
        here = s[i] + (track.length if start + step >= n else 0.0)
        if straight[i] and run_start is None:
            run_start = here
        elif not straight[i] and run_start is not None:
            if here - run_start > best_run:
                best, best_run = (run_start, here), here - run_start
            run_start = None
    return float(best[0]), float(best[1])


def placements(scenario: Scenario, track: Track, gap: float, leader_pace: float) -> tuple[Placement, Placement]:
    """(leader's, follower's) placement: rolling in the racing lane at the scenario's place, ``gap`` apart."""
    start, end = longest_straight(track)
    lead_s = start + STRAIGHT_ENTRY if scenario.place == "straight" else end - CORNER_BEFORE
    lead_s = max(lead_s, start + gap + 1.0) % track.length  # the follower on the straight too
    line = optimise_racing_line(track, PAPER_KART)
    speed = ROLLING_FRACTION * leader_pace * float(line.speed_at(float(lead_s)))
    lane = _racing_lane_at(track, lead_s)
    return Placement(lead_s, lane, speed), Placement(lead_s - gap, lane, speed)  # (behind the line: lap -1)


def race_laps(scenario: Scenario, track: Track, lead: Placement) -> int:
    """The race's laps: it ends at the line, so a start in the second half of a lap races one lap more and every
    attempt drives the scenario's laps within half a lap."""
    return scenario.laps + (1 if lead.progress % track.length > 0.5 * track.length else 0)


def _racing_lane_at(track: Track, s: float) -> int:
    section = int(np.searchsorted(track.checkpoint_s, s, side="right")) - 1
    lane = track.racing_lanes[section % track.n_checkpoints]
    return int(lane) if lane is not None else 2


def attempt_seed(scenario: str, track: str, attempt: int, seed: int) -> int:
    """Attempt ``attempt``'s seed: the same for every cell of the scenario on the track (paired cells)."""
    digest = [ord(c) for c in f"{scenario}/{track}"]
    return int(np.random.SeedSequence([seed, attempt, *digest]).generate_state(1)[0] % 2**31)


def attempt_specs(scenario: Scenario, cell: Cell, attempts: int, seed: int = 0, first: int = 0) -> list[RaceSpec]:
    """The races of attempts ``first`` to ``first + attempts - 1`` of ``cell`` (the ego is kart 0)."""
    track = load_any_track(cell.track)
    ego, opponent = cell.agents(scenario.kind)
    leader_pace = cell.pace if scenario.kind == "overtake" else 1.0
    specs = []
    for i in range(first, first + attempts):
        race_seed = attempt_seed(scenario.name, cell.track, i, seed)
        gap = float(np.random.default_rng([race_seed, 0x6A9]).uniform(*scenario.gap_m))
        lead, follow = placements(scenario, track, gap, leader_pace)
        ego_at, opponent_at = (follow, lead) if scenario.kind == "overtake" else (lead, follow)
        specs.append(
            RaceSpec(
                track=cell.track,
                controllers=(ego, opponent),
                laps=race_laps(scenario, track, lead),
                seed=race_seed,
                conditions=scenario.conditions,
                placements=(ego_at, opponent_at),
            )
        )
    return specs


@dataclass(frozen=True)
class Attempt:
    """What one attempt gave the ego (kart 0)."""

    success: bool  # overtake: passed and ahead at the end; defend: still ahead at the end
    time_to_pass: float | None  # [s] from the start until the ego took the place it then held (overtake)
    collisions_at_fault: int
    illegal_lane_changes: int
    opponent_collisions_at_fault: int


def judge(kind: Kind, outcome: RaceOutcome, first_pass_step: int | None) -> Attempt:
    """The ego's attempt from its race's result; ``first_pass_step``: the step its first pass counted."""
    ego, opponent = outcome.result.karts
    ahead = ego.position < opponent.position
    passed = ego.passes > 0
    time_to_pass = None
    if kind == "overtake" and first_pass_step is not None:
        time_to_pass = max(first_pass_step + 1 - PASS_HOLD_STEPS, 0) * DT  # the place was taken 2 s before
    success = (passed and ahead) if kind == "overtake" else ahead
    return Attempt(
        success, time_to_pass, ego.collisions_at_fault, ego.illegal_lane_changes, opponent.collisions_at_fault
    )


@dataclass(frozen=True)
class CellFigures:
    """A cell's figures over its attempts, with 95% intervals."""

    cell: Cell
    attempts: int
    successes: int
    pass_success: float
    ci95: Interval | None
    time_to_pass: float | None
    time_to_pass_ci95: Interval | None
    collisions_at_fault_per_attempt: float
    collisions_ci95: Interval | None
    illegal_lane_changes_per_attempt: float
    illegal_lane_changes_ci95: Interval | None
    opponent_collisions_at_fault_per_attempt: float

    @classmethod
    def of(cls, cell: Cell, attempts: Sequence[Attempt]) -> CellFigures:
        """The figures of ``attempts`` of ``cell``."""
        n = len(attempts)
        wins = sum(a.success for a in attempts)
        times = [a.time_to_pass for a in attempts if a.success and a.time_to_pass is not None]
        faults = [float(a.collisions_at_fault) for a in attempts]
        lanes = [float(a.illegal_lane_changes) for a in attempts]
        return cls(
            cell,
            n,
            wins,
            wins / n if n else 0.0,
            wilson(wins, n),
            float(np.mean(times)) if times else None,
            bootstrap_mean(times),
            float(np.mean(faults)) if n else 0.0,
            bootstrap_mean(faults),
            float(np.mean(lanes)) if n else 0.0,
            bootstrap_mean(lanes),
            float(np.mean([a.opponent_collisions_at_fault for a in attempts])) if n else 0.0,
        )

    def to_json(self) -> dict[str, Any]:
        """The cell and its figures (the keys ``karting scenarios run --json`` prints)."""
        data = {**asdict(self.cell), **{k: v for k, v in asdict(self).items() if k != "cell"}}
        for key in ("ci95", "time_to_pass_ci95", "collisions_ci95", "illegal_lane_changes_ci95"):
            interval = getattr(self, key)
            data[key] = None if interval is None else [interval.low, interval.high]
        return data


Progress = Callable[[int, int], None]  # (attempts done, attempts in all)


class RunStoppedError(Exception):
    """A run was asked to stop (:func:`run_cells` ``should_stop``) before every cell was done."""


def run_cells(
    scenario: Scenario,
    cells: Sequence[Cell],
    attempts: int,
    seed: int = 0,
    batch: int = 16,
    progress: Progress | None = None,
    workers: int = 1,
    should_stop: Callable[[], bool] | None = None,
) -> list[CellFigures]:
    """Race ``attempts`` attempts of every cell, ``batch`` races at a time in one batched world; with ``workers``
    above 1 the cells go to that many worker processes, one cell at a time. ``should_stop`` is asked between
    batches (between cells with workers): true raises :class:`RunStoppedError`."""
    if workers > 1 and len(cells) > 1:
        return _run_in_workers(scenario, cells, attempts, seed, batch, progress, workers, should_stop)
    specs = [(c, spec) for c in cells for spec in attempt_specs(scenario, c, attempts, seed)]
    results: dict[Cell, list[Attempt]] = {c: [] for c in cells}
    done = 0
    for group in _batches(specs, batch):
        if should_stop is not None and should_stop():
            raise RunStoppedError(f"stopped after {done} of {len(specs)} attempts")
        first_pass: dict[int, int] = {}

        def note_pass(world: World, race: int, _drivers: object, step: int, _seen: dict[int, int] = first_pass) -> None:
            if race not in _seen and world.istate[race, 0, st.I_PASSES] > 0:
                _seen[race] = step

        outcomes = run_races([spec for _, spec in group], on_step=note_pass)
        for index, ((cell, _), outcome) in enumerate(zip(group, outcomes, strict=True)):
            results[cell].append(judge(scenario.kind, outcome, first_pass.get(index)))
        done += len(group)
        if progress is not None:
            progress(done, len(specs))
    return [CellFigures.of(c, results[c]) for c in cells]


def _run_in_workers(
    scenario: Scenario,
    cells: Sequence[Cell],
    attempts: int,
    seed: int,
    batch: int,
    progress: Progress | None,
    workers: int,
    should_stop: Callable[[], bool] | None,
) -> list[CellFigures]:
    context = multiprocessing.get_context(start_method())
    by_cell: dict[Cell, CellFigures] = {}
    with ProcessPoolExecutor(min(workers, len(cells)), mp_context=context) as pool:  # type: ignore[arg-type]
        futures = [pool.submit(run_cells, scenario, [cell], attempts, seed, batch) for cell in cells]
        pending = set(futures)
        while pending:
            done, pending = wait(pending, timeout=1.0, return_when=FIRST_COMPLETED)
            for future in done:
                (figures,) = future.result()
                by_cell[figures.cell] = figures
            if progress is not None and done:
                progress(len(by_cell) * attempts, len(cells) * attempts)
            if pending and should_stop is not None and should_stop():
                for future in pending:
                    future.cancel()  # the cells under way finish; the rest never start
                raise RunStoppedError(f"stopped after {len(by_cell)} of {len(cells)} cells")
    return [by_cell[c] for c in cells]


def _batches(specs: Sequence[tuple[Cell, RaceSpec]], size: int) -> Iterable[list[tuple[Cell, RaceSpec]]]:
    """Runs of ``specs`` that share a batch key, at most ``size`` long."""
    group: list[tuple[Cell, RaceSpec]] = []
    for item in specs:
        if group and (len(group) >= size or batch_key(item[1]) != batch_key(group[0][1])):
            yield group
            group = []
        group.append(item)
    if group:
        yield group


def pass_thresholds(figures: Sequence[CellFigures]) -> dict[str, dict[str, float | None]]:
    """Per ego and opponent: r50, the highest leader pace at which the ego passed in at least half the attempts,
    pooled over the tracks and scenarios given (over the paces measured; ``None``: at none)."""
    pooled: dict[tuple[str, str, float], list[int]] = {}
    for f in figures:
        counts = pooled.setdefault((f.cell.ego, f.cell.opponent, f.cell.pace), [0, 0])
        counts[0] += f.successes
        counts[1] += f.attempts
    found: dict[str, dict[str, float | None]] = {}
    for (ego, opponent, pace), (wins, n) in sorted(pooled.items()):
        row = found.setdefault(ego, {})
        row.setdefault(opponent, None)
        if n and wins / n >= 0.5:
            row[opponent] = max(pace, row[opponent] or 0.0)
    return found


def cells_of(
    scenario: Scenario,
    egos: Sequence[str],
    opponents: Sequence[str],
    tracks: Sequence[str] | None = None,
    paces: Sequence[float] | None = None,
) -> list[Cell]:
    """Every cell of ``scenario`` for these egos and opponents (an ego never against itself), on its tracks and
    paces unless given; ``ValueError``/``KeyError`` for a bad agent."""
    for agent in (*egos, *opponents):
        validate_agent(agent)
    if paces is not None and any(not MIN_PACE <= p <= 1.0 for p in paces):
        raise ValueError(f"paces must be in [{MIN_PACE:g}, 1], got {list(paces)}")
    return [
        Cell(scenario.name, track, ego, opponent, pace)
        for track in (tracks or scenario.tracks)
        for ego in egos
        for opponent in opponents
        if opponent != ego
        for pace in (paces or scenario.paces)
    ]


@dataclass(frozen=True)
class SuiteResult:
    """What ``karting scenarios run`` measured: each scenario with its cells' figures."""

    runs: tuple[tuple[Scenario, tuple[CellFigures, ...]], ...]
    attempts: int
    seed: int

    def to_json(self) -> dict[str, Any]:
        """The printed / stored summary: every cell, and the pass thresholds over the overtaking scenarios."""
        overtakes = [f for scenario, cells in self.runs if scenario.kind == "overtake" for f in cells]
        return {
            "attempts": self.attempts,
            "seed": self.seed,
            "scenarios": {scenario.name: scenario.to_json() for scenario, _ in self.runs},
            "cells": [f.to_json() for _, cells in self.runs for f in cells],
            "pass_threshold_r50": pass_thresholds(overtakes),
        }
