"""Where a field's collisions at fault happen: each one's checkpoint and lap, found by re-simulating the race from its
replay (:func:`controllers.timeline.resimulate`), and per track the checkpoints with the most of them.

A field's safety figure says how many contacts each agent is charged; this says where: a first corner that eight
karts reach together, or one hairpin every lap, is a different problem from contacts spread round the lap.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from arena.race import FinishedRace
from controllers.race import load_any_track
from controllers.timeline import COLLISION_AT_FAULT, resimulate
from sim_core.params import SimParams, kart_preset

HOTSPOTS = 3  # checkpoints named per track


@dataclass(frozen=True)
class FaultPlace:
    """One collision at fault: the kart charged, when, and the checkpoint it had last passed (0-based within the
    lap) on which lap (1-based)."""

    track: str
    agent: str
    time: float  # [s] race time
    checkpoint: int
    lap: int

    def to_json(self) -> list[Any]:
        """[agent, time, checkpoint, lap]."""
        return [self.agent, round(self.time, 2), self.checkpoint, self.lap]


def fault_places(race: FinishedRace) -> list[FaultPlace]:
    """Every collision at fault of ``race`` (raced with a replay) and where it happened."""
    if race.replay is None:
        raise ValueError(f"race {race.job.index} has no replay: race it with record=True")
    spec = race.job.spec()
    track = load_any_track(spec.track)
    poses = np.asarray(race.replay["poses"], dtype=np.float64).reshape(-1, len(spec.controllers), 6)
    drawn = spec.drawn()
    params = SimParams(kart=kart_preset(spec.kart_preset))
    timeline = resimulate(poses, track, race.laps, params, spec.start_lanes, drawn, spec.kart_paces(drawn))
    places = []
    n = track.n_checkpoints
    for incident in timeline.incidents:
        if incident.kind != COLLISION_AT_FAULT:
            continue
        step = min(round(incident.time / timeline.dt), timeline.steps)
        passed = int(timeline.checkpoints_passed[step, incident.kart])
        places.append(
            FaultPlace(spec.track, spec.controllers[incident.kart], incident.time, passed % n, passed // n + 1)
        )
    return places


@dataclass(frozen=True)
class Hotspots:
    """A track's collisions at fault by place: how many, the share in the first lap, the checkpoints with most."""

    track: str
    faults: int
    first_lap: int
    top: tuple[tuple[int, int], ...]  # (checkpoint, collisions at fault after it), most first

    def to_json(self) -> dict[str, Any]:
        """The figures as plain data."""
        return {
            "track": self.track,
            "faults": self.faults,
            "first_lap": self.first_lap,
            "top": [list(t) for t in self.top],
        }


def hotspots(track: str, places: Sequence[FaultPlace], top: int = HOTSPOTS) -> Hotspots:
    """``track``'s figures from ``places`` (those of other tracks are left out); ties by checkpoint order."""
    mine = [p for p in places if p.track == track]
    counts = Counter(p.checkpoint for p in mine)
    ranked = sorted(counts.items(), key=lambda item: (-item[1], item[0]))[:top]
    return Hotspots(track, len(mine), sum(p.lap == 1 for p in mine), tuple(ranked))


def hotspot_lines(spots: Sequence[Hotspots]) -> list[str]:
    """The README's section: per track, the collisions at fault in the first lap and after the busiest checkpoints."""
    lines = [
        "## Where the collisions at fault happen",
        "",
        "Each race re-simulated from its replay: the checkpoint each kart charged had last passed (0: the start "
        "line) and on which lap.",
        "",
        "| track | collisions at fault | in the first lap | after the busiest checkpoints |",
        "|---|---|---|---|",
    ]
    for s in spots:
        share = f"{s.first_lap} ({100 * s.first_lap / s.faults:.0f}%)" if s.faults else "0"
        busiest = ", ".join(f"{cp}: {n} ({100 * n / s.faults:.0f}%)" for cp, n in s.top) if s.faults else "-"
        lines.append(f"| `{s.track}` | {s.faults} | {share} | {busiest} |")
    return [*lines, ""]
