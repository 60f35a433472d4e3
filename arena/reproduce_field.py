"""The free-for-all field study (``karting reproduce field``): the paper's five agents in 8-kart races on ``oval``,
``complex`` and the imported ``brands-hatch`` under ``varied-equal-distance`` conditions (:mod:`arena.field`: every
kart finishes after the same distance from its own slot), written into
``OUT/``: ``README.md`` (per track: each agent's finish rate, collisions at fault and illegal lane changes per
kart-race against the field targets, the ratings from the finishing orders, the wins by grid slot),
``field.json`` (every figure and every kart of every race) and ``manifest.json``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from arena.field import FieldFigures, FieldSpec, field_figures, row_effect, slot_wins
from arena.field_compare import PairedChange, baseline_section, change_json, field_races, paired_changes
from arena.field_places import FaultPlace, fault_places, hotspot_lines, hotspots
from arena.intervals import Interval
from arena.manifest import build_manifest, describe_agent, source_commit, time_limit_of
from arena.ratings import ratings
from arena.records import PER_STEP, RaceFigures
from arena.reproduce import PAPER_AGENTS
from arena.stats import COMBINED
from arena.tournament import race_stream

DEFAULT_FIELD_RACES = 40  # per track: eight turns of the five-agent rotation
DEFAULT_FIELD_OUT = Path("docs/results/field")  # where `karting reproduce field` writes unless told
# [s] the races' time limit: the rules' 120 s (set for the paper's tracks) ends brands-hatch's three laps of about
# 40 s before the slower agents finish; a field's finish rate must measure the driving, not the clock
FIELD_TIME_LIMIT = 240.0
# the field targets: every kart finishes, few collisions at fault and illegal lane changes per kart-race
TARGET_FINISH_RATE = 0.95
TARGET_COLLISIONS = 0.3
TARGET_ILLEGAL = 0.2


def field_spec(
    races_per_track: int = DEFAULT_FIELD_RACES, seed: int = 0, agents: Sequence[str] = PAPER_AGENTS
) -> FieldSpec:
    """The study: ``agents`` (the paper's five by default) in 8-kart fields, ``races_per_track`` races per track."""
    return FieldSpec(tuple(agents), races_per_track=races_per_track, seed=seed, time_limit=FIELD_TIME_LIMIT).validate()


def run_field(
    spec: FieldSpec,
    workers: int | None = None,
    on_race: Callable[[int, int], None] | None = None,
    places: list[FaultPlace] | None = None,
) -> list[RaceFigures]:
    """Every race of ``spec`` (worker processes), in schedule order; ``on_race(done, total)`` after each. With
    ``places``, the races are recorded and every collision at fault's place is appended to it, in schedule order
    (:func:`arena.field_places.fault_places`; each replay is dropped once read)."""
    source_commit()  # the code the races run with, before the study writes anything (the manifest's commit)
    finished: dict[int, RaceFigures] = {}
    found: dict[int, list[FaultPlace]] = {}
    for race in race_stream(spec.jobs(), workers=workers, record=places is not None):
        finished[race.job.index] = race.figures()
        if places is not None:
            found[race.job.index] = fault_places(race)
        if on_race is not None:
            on_race(len(finished), spec.total)
    if places is not None:
        places.extend(place for i in sorted(found) for place in found[i])
    return [finished[i] for i in sorted(finished)]


def _interval(value: float, ci: Interval | None, digits: int = 2) -> str:
    low_high = "" if ci is None else f" [{ci.low:.{digits}f}, {ci.high:.{digits}f}]"
    return f"{value:.{digits}f}{low_high}"


def _finished_text(f: FieldFigures) -> str:
    ci = f.finished_ci95
    low_high = "" if ci is None else f" [{100 * ci.low:.0f}, {100 * ci.high:.0f}]"
    return f"{f.finished}/{f.karts} = {100 * f.finish_rate:.1f}%{low_high}"


def _per_track(spec: FieldSpec, races: Sequence[RaceFigures]) -> dict[str, list[RaceFigures]]:
    return {track: [r for r in races if track in (COMBINED, r.track)] for track in (*spec.tracks, COMBINED)}


def field_findings(
    spec: FieldSpec,
    races: Sequence[RaceFigures],
    wall_s: float,
    baseline: tuple[Path, Sequence[PairedChange]] | None = None,
    out: Path = DEFAULT_FIELD_OUT,
    places: Sequence[FaultPlace] | None = None,
) -> str:
    """The study's README (``baseline``: the study it was raced against, and the paired changes; ``out``: where it
    is written, named in the command that regenerates it unless the default; ``places``: where the collisions at
    fault happened)."""
    agents = "" if spec.agents == tuple(PAPER_AGENTS) else f" --agents {','.join(spec.agents)}"
    if baseline is not None:
        agents += f" --baseline {baseline[0]}"
    if out != DEFAULT_FIELD_OUT:
        agents += f" --out {out}"
    lines = [
        f"# Fields: {'the five' if not agents else len(spec.agents)} agents in {spec.field_size}-kart free-for-all "
        "races",
        "",
        f"Regenerated by `karting reproduce field --races {spec.races_per_track} --seed {spec.seed}{agents}` "
        f"({len(races)} races, {wall_s / 60:.0f} min on this machine; `manifest.json` says which code and agents).",
        "",
        f"- {spec.field_size} karts per race on {', '.join(f'`{t}`' for t in spec.tracks)}, "
        f"{spec.races_per_track} races per track under `{spec.conditions}` conditions (seeded per race), "
        f"a time limit of {time_limit_of(spec.time_limit):.0f} s.",
        "- The grid: two rows of four (lanes 2, 3, 1, 4), the second behind the first. The agents fill the "
        "slots in turn from a different first agent each pair of races, so each agent starts from each slot equally "
        "often (three agents have two karts in each race)"
        + (
            "; races come in reversed pairs: the same seed, the second with the first's grid reversed (pole last, "
            "last on pole), so every kart starts once from each row under the same conditions."
            if spec.reversed_pairs
            else "."
        ),
        f"- Targets for a field: every kart finishes in at least {TARGET_FINISH_RATE:.0%} of races; at most "
        f"{TARGET_COLLISIONS} collisions at fault and {TARGET_ILLEGAL} illegal lane changes (per-step rule) "
        "per kart-race.",
        "- Intervals are 95%: Wilson for shares, bootstrap over karts for means, bootstrap over races for ratings.",
        "",
    ]
    for track, subset in _per_track(spec, races).items():
        lines += _track_section(track, subset)
    if places is not None:
        lines += hotspot_lines([hotspots(track, places) for track in spec.tracks])
    lines += _slot_section(races, spec.field_size)
    lines += _row_section(races)
    if baseline is not None:
        lines += baseline_section(*baseline)
    return "\n".join(lines)


def _track_section(track: str, races: Sequence[RaceFigures]) -> list[str]:
    figures = field_figures(races)
    rated = ratings(races)
    lines = [
        f"## {'All tracks' if track == COMBINED else f'`{track}`'} ({len(races)} races)",
        "",
        "| agent | karts finished | races won | collisions at fault per kart-race | illegal lane changes per "
        "kart-race | rating (log-strength) |",
        "|---|---|---|---|---|---|",
    ]
    for rating in rated:
        f = figures[rating.agent]
        theta = _interval(rating.theta, rating.ci95)
        lines.append(
            f"| {f.agent} | {_finished_text(f)} | {f.wins}/{f.races} | "
            f"{_interval(f.collisions_at_fault, f.collisions_ci95)} | "
            f"{_interval(f.illegal_lane_changes, f.illegal_ci95)} | {theta} |"
        )
    met = [
        _verdict("finish rate", all(f.finish_rate >= TARGET_FINISH_RATE for f in figures.values())),
        _verdict("collisions", all(f.collisions_at_fault <= TARGET_COLLISIONS for f in figures.values())),
        _verdict("illegal lane changes", all(f.illegal_lane_changes <= TARGET_ILLEGAL for f in figures.values())),
    ]
    return [*lines, "", "Targets for every agent: " + "; ".join(met) + ".", ""]


def _verdict(name: str, met: bool) -> str:
    return f"{name} {'met' if met else 'missed'}"


def _slot_section(races: Sequence[RaceFigures], size: int) -> list[str]:
    wins = slot_wins(races)
    decided = sum(wins)
    front = sum(wins[: min(4, size)])
    header = " | ".join(str(s + 1) for s in range(size))
    return [
        "## Wins by grid slot (all tracks)",
        "",
        f"| slot | {header} |",
        f"|---|{'---|' * size}",
        f"| races won | {' | '.join(str(w) for w in wins)} |",
        "",
        f"The front row (slots 1-4) won {front} of {decided} decided races "
        f"({100 * front / max(decided, 1):.0f}%; half of the slots). The rotation gives every agent each slot "
        "equally often, so a place in front does not favour an agent; what it decides is this share.",
        "",
    ]


def _row_section(races: Sequence[RaceFigures]) -> list[str]:
    effect = row_effect(races)
    if effect is None:
        return []
    lines = [
        "## The front row, paired (all tracks)",
        "",
        f"Over {effect.pairs} reversed pairs (the same seed, the grid reversed), the places a kart lost starting "
        "from the back row instead of the front, under the same conditions (positive: the front row helped):",
        "",
        "| agent | places lost from the back row |",
        "|---|---|",
        *(f"| {agent} | {_interval(mean, ci)} |" for agent, (mean, ci) in effect.per_agent.items()),
        f"| every kart | {_interval(effect.places_lost, effect.places_lost_ci95)} |",
        "",
        f"The same agent won both races of {effect.same_winner} of {effect.pairs} pairs; in the others the grid "
        "decided which agent won.",
        "",
    ]
    return lines


def field_json(spec: FieldSpec, races: Sequence[RaceFigures], wall_s: float) -> dict[str, Any]:
    """Every figure per track, the ratings, the slot wins, and every kart of every race."""
    per_track = _per_track(spec, races)
    return {
        "spec": spec.to_json(),
        "wall_seconds": wall_s,
        "tracks": {
            track: {
                "agents": {a: f.to_json() for a, f in field_figures(subset).items()},
                "ratings": [r.to_json() for r in ratings(subset)],
            }
            for track, subset in per_track.items()
        },
        "slot_wins": slot_wins(races),
        "row_effect": None if (effect := row_effect(races)) is None else effect.to_json(),
        "races": [
            {
                "track": r.track,
                "seed": r.seed,
                "karts": [
                    {
                        "agent": k.agent,
                        "finished": k.finished,
                        "time": k.total_time,
                        "collisions_at_fault": k.collisions_at_fault,
                        "illegal_lane_changes": k.illegal_lane_changes[PER_STEP],
                    }
                    for k in r.karts
                ],
            }
            for r in races
        ],
    }


def write_field(
    out: Path,
    spec: FieldSpec,
    races: Sequence[RaceFigures],
    wall_s: float,
    baseline: Path | None = None,
    places: Sequence[FaultPlace] | None = None,
) -> None:
    """``OUT/README.md``, ``OUT/field.json`` and ``OUT/manifest.json``; with ``baseline`` (a study of the same
    schedule: its folder or ``field.json``) each agent's collisions paired race by race against it too; with
    ``places``, where the collisions at fault happened."""
    # the manifest first: the files written here are tracked, and would otherwise count as changed code
    manifest = build_manifest("field", [describe_agent(a) for a in spec.agents], "paper", spec.to_json())
    compared = None if baseline is None else (baseline, paired_changes(field_races(baseline), races))
    data = field_json(spec, races, wall_s)
    if compared is not None:
        data["baseline"] = {"study": str(baseline), "changes": [change_json(c) for c in compared[1]]}
    if places is not None:
        data["collision_places"] = {
            "hotspots": [hotspots(track, places).to_json() for track in spec.tracks],
            "faults": [{"track": p.track, "place": p.to_json()} for p in places],
        }
    out.mkdir(parents=True, exist_ok=True)
    (out / "README.md").write_text(field_findings(spec, races, wall_s, compared, out, places))
    (out / "field.json").write_text(json.dumps(data, indent=1) + "\n")
    (out / "manifest.json").write_text(json.dumps(manifest.to_json(), indent=1) + "\n")


def reproduce_field(out: Path, spec: FieldSpec, workers: int | None = None) -> float:
    """Run ``spec`` and write it into ``out``; returns the wall time [s]."""
    started = time.perf_counter()
    places: list[FaultPlace] = []
    races = run_field(spec, workers, places=places)
    wall = time.perf_counter() - started
    write_field(out, spec, races, wall, places=places)
    return wall
