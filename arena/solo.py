"""Solo laps (``karting solo``): each agent alone on each track, its lap times and its wall touches.

What an agent does with no kart near it: its pace (the best lap and the mean of the laps after the first, which
starts from a standstill) and how often it touches a wall (the referee's wall hits: contacts separated by more than
the fault cooldown). The figures a change to an agent's driving must not worsen, and the field issue's check of
the RL agents (no wall touched alone on ``oval``, ``complex`` and an imported circuit, best laps within 1% of the
shipped agents'). Each race starts from lane 2, seeded ``seed + i`` under the named conditions (under ``paper``
every race of an agent and track is the same race).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from statistics import fmean
from typing import Any

from arena.manifest import build_manifest, describe_agent
from arena.race import FinishedRace, RaceJob
from arena.tournament import race_stream

SOLO_TIME_LIMIT = 300.0  # [s] long enough for three laps of the slowest agent on the longest built-in track
SOLO_START_LANE = 2


@dataclass(frozen=True)
class SoloFigures:
    """One agent alone on one track, over ``races`` races."""

    agent: str
    track: str
    conditions: str
    races: int
    finished: int  # races it finished within the time limit
    best_lap: float | None  # [s] its fastest lap of any race
    mean_flying_lap: float | None  # [s] the mean of its laps after the first (a standing start)
    wall_hits: int  # in all its races

    @property
    def wall_hits_per_race(self) -> float:
        """Wall hits per race."""
        return self.wall_hits / self.races

    def to_json(self) -> dict[str, Any]:
        """The figures as plain data."""
        return {
            "agent": self.agent,
            "track": self.track,
            "conditions": self.conditions,
            "races": self.races,
            "finished": self.finished,
            "best_lap": self.best_lap,
            "mean_flying_lap": self.mean_flying_lap,
            "wall_hits": self.wall_hits,
            "wall_hits_per_race": round(self.wall_hits_per_race, 3),
        }


def solo_jobs(
    agents: Sequence[str], tracks: Sequence[str], races: int = 1, seed: int = 0, conditions: str = "paper"
) -> list[RaceJob]:
    """The races: every agent alone on every track, ``races`` each (seeds ``seed``, ``seed + 1``, ...)."""
    if races < 1:
        raise ValueError(f"races must be >= 1, got {races}")
    if not agents or not tracks:
        raise ValueError("name at least one agent and one track")
    return [
        RaceJob(
            index=len(agents) * races * t + races * a + i,
            track=track,
            agents=(agent,),
            seed=seed + i,
            start_lanes=(SOLO_START_LANE,),
            time_limit=SOLO_TIME_LIMIT,
            conditions=conditions,
        )
        for t, track in enumerate(tracks)
        for a, agent in enumerate(agents)
        for i in range(races)
    ]


def solo_figures(finished: Sequence[FinishedRace]) -> list[SoloFigures]:
    """Each (agent, track)'s figures from its races, in the order the races were scheduled."""
    groups: dict[tuple[str, str], list[FinishedRace]] = {}
    for race in sorted(finished, key=lambda r: r.job.index):
        groups.setdefault((race.job.agents[0], race.job.track), []).append(race)
    figures = []
    for (agent, track), group in groups.items():
        by_race = [race.lap_times[0] if race.lap_times else () for race in group]
        laps = [lap for race_laps in by_race for lap in race_laps]
        flying = [lap for race_laps in by_race for lap in race_laps[1:]]
        figures.append(
            SoloFigures(
                agent=agent,
                track=track,
                conditions=group[0].job.conditions,
                races=len(group),
                finished=sum(race.result.karts[0].finished for race in group),
                best_lap=round(min(laps), 3) if laps else None,
                mean_flying_lap=round(fmean(flying), 3) if flying else None,
                wall_hits=sum(race.result.karts[0].wall_hits for race in group),
            )
        )
    return figures


def run_solo(
    agents: Sequence[str],
    tracks: Sequence[str],
    races: int = 1,
    seed: int = 0,
    conditions: str = "paper",
    workers: int | None = None,
) -> list[SoloFigures]:
    """Race :func:`solo_jobs` in worker processes and return their :func:`solo_figures`."""
    return solo_figures(list(race_stream(solo_jobs(agents, tracks, races, seed, conditions), workers=workers)))


def solo_readme(figures: Sequence[SoloFigures], command: str, wall_s: float) -> str:
    """The published table: per agent and track, races finished, best lap, mean flying lap and wall hits."""
    lines = [
        "# Solo laps: each agent alone on each track",
        "",
        f"Regenerated by `{command}` ({len(figures)} agent-track pairs, {wall_s / 60:.1f} min on this machine;"
        " `manifest.json` says which code and agents).",
        "",
        f"- Each race from lane {SOLO_START_LANE}, the track's laps, a time limit of {SOLO_TIME_LIMIT:.0f} s;"
        " the flying laps are those after the standing start.",
        "- Wall hits: the referee's (contacts with a wall separated by more than the fault cooldown).",
        "- The field issue's check of the RL agents: no wall touched alone on `oval`, `complex` and an imported"
        " circuit (`brands-hatch`, `norisring`).",
        "",
        "| agent | track | finished | best lap [s] | mean flying lap [s] | wall hits per race |",
        "|---|---|---|---|---|---|",
    ]
    for f in figures:
        best = "-" if f.best_lap is None else f"{f.best_lap:.2f}"
        mean = "-" if f.mean_flying_lap is None else f"{f.mean_flying_lap:.2f}"
        row = f"| {f.agent} | {f.track} | {f.finished}/{f.races} | {best} | {mean} | {f.wall_hits_per_race:.1f} |"
        lines.append(row)
    return "\n".join(lines) + "\n"


def publish_solo(
    out: Path, figures: Sequence[SoloFigures], spec: Mapping[str, Any], command: str, wall_s: float
) -> None:
    """``OUT/README.md``, ``OUT/solo.json`` and ``OUT/manifest.json`` (``spec``: what was raced, as plain data)."""
    # the manifest first: the files written here are tracked, and would otherwise count as changed code
    agents = list(dict.fromkeys(f.agent for f in figures))
    manifest = build_manifest("solo", [describe_agent(a) for a in agents], "paper", dict(spec))
    out.mkdir(parents=True, exist_ok=True)
    (out / "README.md").write_text(solo_readme(figures, command, wall_s))
    data = {"spec": dict(spec), "wall_seconds": round(wall_s, 1), "solo": [f.to_json() for f in figures]}
    (out / "solo.json").write_text(json.dumps(data, indent=1) + "\n")
    (out / "manifest.json").write_text(json.dumps(manifest.to_json(), indent=1) + "\n")
