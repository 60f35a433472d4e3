"""Two field studies of one schedule compared race by race: the agents of a study against a baseline study whose
race ``i`` had the same track, seed and grid, with some agents swapped for variants (``mcts-rl`` for
``mcts-rl-adaptive``, say). Each race is its own control, so the change in an agent's collisions at fault per
kart-race is measured on the same conditions and the same places on the grid, with a bootstrap interval over
races.

:func:`field_races` reads a study's ``field.json`` back (every kart of every race), so a baseline needs no
database.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from statistics import fmean

from arena.intervals import Interval, bootstrap_mean, interval_json
from arena.records import CHECKPOINT, PER_STEP, KartFigures, RaceFigures


def field_races(path: Path) -> list[RaceFigures]:
    """The races of the field study whose ``field.json`` is ``path`` (or the folder holding it), in schedule
    order; ``ValueError`` when it holds no races."""
    file = path / "field.json" if path.is_dir() else path
    races = json.loads(file.read_text()).get("races")
    if not races:
        raise ValueError(f"{file} holds no field races")
    return [
        RaceFigures(
            race["track"],
            tuple(
                KartFigures(
                    kart["agent"],
                    kart["finished"],
                    kart["time"],
                    kart["collisions_at_fault"],
                    {PER_STEP: kart["illegal_lane_changes"], CHECKPOINT: 0},
                    PER_STEP,
                )
                for kart in race["karts"]
            ),
            index=i,
            seed=race["seed"],
        )
        for i, race in enumerate(races)
    ]


@dataclass(frozen=True)
class PairedChange:
    """One agent of a study against the baseline's agent in its grid slots, over the races both ran."""

    baseline_agent: str
    agent: str
    races: int
    baseline_collisions: float  # at fault per kart-race
    collisions: float
    change: float  # the mean over races of (this race's per-kart mean - the baseline race's)
    change_ci95: Interval | None
    baseline_time: float | None  # [s] mean race time of its karts that finished
    time: float | None


def agent_swaps(baseline: Sequence[RaceFigures], races: Sequence[RaceFigures]) -> dict[str, str]:
    """Each study agent's baseline agent (the one in its grid slots); ``ValueError`` unless the two studies ran the
    same schedule (track and seed per race) with one agent swapped for one agent throughout."""
    if len(baseline) != len(races):
        raise ValueError(f"the baseline has {len(baseline)} races, this study {len(races)}")
    swaps: dict[str, str] = {}
    for i, (old, new) in enumerate(zip(baseline, races, strict=True)):
        if (old.track, old.seed, len(old.karts)) != (new.track, new.seed, len(new.karts)):
            raise ValueError(
                f"race {i}: the baseline ran {old.track} seed {old.seed}, this study {new.track} {new.seed}"
            )
        for before, after in zip(old.agents, new.agents, strict=True):
            if swaps.setdefault(after, before) != before:
                raise ValueError(f"race {i}: {after} sits where the baseline had {before} and {swaps[after]}")
    if len(set(swaps.values())) != len(swaps):
        raise ValueError("two agents of this study sit in the slots of one baseline agent")
    return swaps


def _mean_time(karts: list[KartFigures]) -> float | None:
    times = [k.total_time for k in karts if k.finished and k.total_time is not None]
    return fmean(times) if times else None


def paired_changes(baseline: Sequence[RaceFigures], races: Sequence[RaceFigures]) -> list[PairedChange]:
    """Per agent of this study (sorted), its collisions at fault per kart-race against the baseline agent's in
    the same slots of the same races, and the paired change with its bootstrap interval over races."""
    swaps = agent_swaps(baseline, races)
    changes = []
    for agent, before in sorted(swaps.items()):
        olds, news, deltas = [], [], []
        for old, new in zip(baseline, races, strict=True):
            mine = [k for k in new.karts if k.agent == agent]
            theirs = [k for k in old.karts if k.agent == before]
            if not mine:
                continue
            olds += theirs
            news += mine
            deltas.append(fmean(k.collisions_at_fault for k in mine) - fmean(k.collisions_at_fault for k in theirs))
        changes.append(
            PairedChange(
                before,
                agent,
                len(deltas),
                fmean(k.collisions_at_fault for k in olds),
                fmean(k.collisions_at_fault for k in news),
                fmean(deltas),
                bootstrap_mean(deltas),
                _mean_time(olds),
                _mean_time(news),
            )
        )
    return changes


def _seconds(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"


def baseline_section(baseline: Path, changes: Sequence[PairedChange]) -> list[str]:
    """The README section of a study raced against ``baseline``."""
    lines = [
        f"## Against the baseline study [`{baseline}`]",
        "",
        "Race by race against the baseline study: the same track, seed and grid in every race, each agent here in "
        "the slots its baseline agent held there. Collisions at fault per kart-race, and the paired change (the "
        "mean over races of each race's difference; 95% bootstrap interval over races); mean race times of the "
        "karts that finished.",
        "",
        "| agent | in the baseline | collisions at fault, baseline | here | paired change | race time [s], "
        "baseline | here |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in changes:
        ci = "" if c.change_ci95 is None else f" [{c.change_ci95.low:+.2f}, {c.change_ci95.high:+.2f}]"
        lines.append(
            f"| {c.agent} | {c.baseline_agent} | {c.baseline_collisions:.2f} | {c.collisions:.2f} | "
            f"{c.change:+.2f}{ci} | {_seconds(c.baseline_time)} | {_seconds(c.time)} |"
        )
    return [*lines, ""]


def change_json(change: PairedChange) -> dict[str, object]:
    """One agent's paired change as JSON (the interval as ``[low, high]``)."""
    return {
        "agent": change.agent,
        "baseline_agent": change.baseline_agent,
        "races": change.races,
        "baseline_collisions_at_fault": change.baseline_collisions,
        "collisions_at_fault": change.collisions,
        "change": change.change,
        "change_ci95": interval_json(change.change_ci95),
        "baseline_time": change.baseline_time,
        "time": change.time,
    }
