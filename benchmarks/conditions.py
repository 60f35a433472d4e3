"""What the race conditions' imprecision does: solo lap times with and without it, and how many different outcomes a
close pairing's races have, at several noise levels (the measurement behind the ``varied`` set's magnitude,
:mod:`sim_core.conditions`).

* ``solo``: per agent and track, the mean solo race time over ``--seeds`` seeds under each noise level (the
  ``varied`` set with its steer and throttle noise scaled by the level; level 0 is ``varied`` without noise, and
  ``paper`` is reported beside it), and its ratio to the ``paper`` time; ``max_solo_ratio_error`` the largest
  |ratio - 1| of the ``varied`` set as shipped (level 1);
* ``pairs``: per close pairing, ``--races`` races (start lanes alternating) under ``paper`` and each level: the
  winners by start lane, and the number of distinct outcomes (winner and finish times to 10 ms).

Run from the repo root: ``.venv/bin/python benchmarks/conditions.py`` (about 10 minutes on one core; ``--help``).
The last line printed is one JSON object.
"""

from __future__ import annotations

import json
from dataclasses import replace

import typer

from controllers.race import RaceSpec, run_race
from sim_core.conditions import PAPER, VARIED, ConditionSet

AGENTS = "mcts-rl,e2e,fixed-rl,mcts-lqng,fixed-lqng"
PAIRS = "mcts-rl/fixed-rl,fixed-lqng/fixed-lqng,mcts-lqng/fixed-lqng"

app = typer.Typer(add_completion=False)


def scaled(level: float) -> ConditionSet:
    """The ``varied`` set with its imprecision scaled by ``level``."""
    return replace(
        VARIED,
        name=f"varied-x{level:g}",
        steer_noise=VARIED.steer_noise * level,
        throttle_noise=VARIED.throttle_noise * level,
    )


def solo_time(agent: str, track: str, conditions: ConditionSet, seed: int, laps: int | None) -> float | None:
    """The solo race time of ``agent`` from its launch (None: it did not finish)."""
    spec = RaceSpec(track=track, controllers=(agent,), seed=seed, laps=laps, start_lanes=(2,), conditions=conditions)
    outcome = run_race(spec)
    finish = outcome.result.karts[0].finish_time
    return None if finish is None else finish - outcome.start_delays[0]  # from its own launch


def outcome(pair: tuple[str, str], track: str, conditions: ConditionSet, race: int, laps: int | None) -> tuple:
    """(winner's start lane or None, finish times to 10 ms) of race ``race`` of ``pair``."""
    lanes = (2, 3) if race % 2 == 0 else (3, 2)
    spec = RaceSpec(track=track, controllers=pair, seed=race, laps=laps, start_lanes=lanes, conditions=conditions)
    result = run_race(spec).result
    winner_lane = None if result.winner is None else lanes[result.winner]
    return winner_lane, tuple(None if k.finish_time is None else round(k.finish_time, 2) for k in result.karts)


@app.command()
def main(
    agents: str = typer.Option(AGENTS, help="agents timed alone, comma separated"),
    pairs: str = typer.Option(PAIRS, help="close pairings, A/B comma separated"),
    tracks: str = typer.Option("oval,complex"),
    levels: str = typer.Option("0,0.5,1,2", help="noise levels: multiples of the varied set's imprecision"),
    seeds: int = typer.Option(3, min=1, help="seeds per solo time"),
    races: int = typer.Option(10, min=2, help="races per pairing, track and level"),
    laps: int | None = typer.Option(None, min=1, help="laps (default: each track's)"),
) -> None:
    """Measure and print the JSON summary as the last line."""
    level_values = [float(x) for x in levels.split(",")]
    summary: dict[str, object] = {
        "varied": VARIED.to_json(),
        "levels": level_values,
        "seeds": seeds,
        "races": races,
    }
    solo: dict[str, dict[str, dict[str, float | None]]] = {}
    worst = 0.0
    for track in tracks.split(","):
        for agent in [a for a in agents.split(",") if a]:
            reference = solo_time(agent, track, PAPER, 0, laps)
            row: dict[str, float | None] = {"paper": reference}
            for level in level_values:
                times = [solo_time(agent, track, scaled(level), seed, laps) for seed in range(seeds)]
                done = [t for t in times if t is not None]
                mean = sum(done) / len(done) if len(done) == len(times) else None
                row[f"x{level:g}"] = mean
                ratio = None if mean is None or reference is None else mean / reference
                row[f"x{level:g}_ratio"] = ratio
                if level == 1.0 and ratio is not None:
                    worst = max(worst, abs(ratio - 1.0))
            solo.setdefault(track, {})[agent] = row
            print(track, agent, json.dumps(row), flush=True)
    summary["solo"] = solo
    summary["max_solo_ratio_error"] = worst
    diversity: dict[str, dict[str, dict[str, object]]] = {}
    for track in tracks.split(","):
        for text in [p for p in pairs.split(",") if p]:
            a, b = text.split("/")
            cells: dict[str, object] = {}
            for name, conditions in [("paper", PAPER)] + [(f"x{lv:g}", scaled(lv)) for lv in level_values]:
                outcomes = [outcome((a, b), track, conditions, r, laps) for r in range(races)]
                lane_two = sum(o[0] == 2 for o in outcomes)
                cells[name] = {
                    "distinct_outcomes": len(set(outcomes)),
                    "won_from_lane_2": lane_two,
                    "first_agent_wins": sum((o[0] == 2) == (r % 2 == 0) for r, o in enumerate(outcomes) if o[0]),
                }
            diversity.setdefault(track, {})[text] = cells
            print(track, text, json.dumps(cells), flush=True)
    summary["pairs"] = diversity
    print(json.dumps(summary))


if __name__ == "__main__":
    app()
