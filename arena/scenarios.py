"""Tactics measured directly: short scenarios from placed karts, many seeded attempts per cell, figures with
intervals (the passing contests of racing robotics: an overtaking success rate against a leader of a given pace,
and the pace at which passes stop succeeding).

A :class:`Scenario` is data (a JSON file: the shipped ones in ``scenarios/``, or a user's own). Its ``kind`` says
where the karts start (:mod:`arena.scenario_setups`), which kart the cell's pace handicaps and what counts as a
success (:func:`arena.scenario_setups.judge`):

* ``overtake``: the ego starts ``gap_m`` behind a leader at each pace of ``paces``, both rolling in the racing
  lane, on a straight or before a corner (``place``). Success: the ego passed (held the place 2 s, the referee's
  count) and is ahead at the end;
* ``defend``: the ego leads at each pace of ``paces`` with a full-pace attacker ``gap_m`` behind. Success: the
  ego is still ahead at the end (the place held);
* ``side-by-side``: the ego and the opponent (at each pace of ``paces``) abreast into a corner, the ego inside
  in even attempts and outside in odd ones. Success: the ego is ahead at the end;
* ``lapping``: the ego behind a slower kart (``backmarker`` at each pace of ``paces``) with the opponent at full
  pace close behind it. Success: the ego passed the slower kart and is ahead of both at the end;
* ``start``: ``karts`` karts from a standing start, the ego and copies of the opponent (at each pace of
  ``paces``), the ego in each grid lane in turn. Success: the ego leads at the end; its mean place is reported.

A cell is (scenario, track, ego, opponent, pace); attempt ``i`` of every cell of a scenario on a track has the
same seed, so the same gap and conditions (a paired design across egos, opponents and paces).
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from arena.intervals import Interval, bootstrap_mean, wilson
from arena.scenario_setups import Attempt, attempt_specs, judge
from arena.scenario_spec import Cell, Scenario
from arena.tournament import start_method
from controllers.race import RaceSpec, batch_key, run_races
from controllers.registry import validate_agent
from sim_core import state as st
from sim_core.params import MIN_PACE
from sim_core.world import World


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
    mean_place: float | None = None  # the ego's place at the end (1: ahead of every kart), over the attempts
    mean_place_ci95: Interval | None = None

    @classmethod
    def of(cls, cell: Cell, attempts: Sequence[Attempt]) -> CellFigures:
        """The figures of ``attempts`` of ``cell``."""
        n = len(attempts)
        wins = sum(a.success for a in attempts)
        times = [a.time_to_pass for a in attempts if a.success and a.time_to_pass is not None]
        faults = [float(a.collisions_at_fault) for a in attempts]
        lanes = [float(a.illegal_lane_changes) for a in attempts]
        places = [float(a.place) for a in attempts if a.place is not None]
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
            float(np.mean(places)) if places else None,
            bootstrap_mean(places),
        )

    def to_json(self) -> dict[str, Any]:
        """The cell and its figures (the keys ``karting scenarios run --json`` prints)."""
        data = {**asdict(self.cell), **{k: v for k, v in asdict(self).items() if k != "cell"}}
        for key in ("ci95", "time_to_pass_ci95", "collisions_ci95", "illegal_lane_changes_ci95", "mean_place_ci95"):
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
