"""A series of headless races between two registered controllers, start lanes alternating, with the paper's
per-race figures summed up. Prints one line per race and a JSON summary as the last line.

    .venv/bin/python scripts/head_to_head.py --track complex --karts mcts-lqng,fixed-lqng --races 50

``--workers N`` races N at a time in separate processes; every race is seeded, so the lines and the summary are
the same as one process gives, in the same order. ``--conditions varied`` draws each race's conditions from its seed
(:mod:`sim_core.conditions`: launch reactions, start wear, the drivers' imprecision): the same conditions for any
pair of controllers, so a series against a control pair is a paired comparison.
"""

from __future__ import annotations

import json
import statistics
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import typer

from controllers.race import RaceSpec, run_race
from controllers.race_metrics import RaceMetrics
from sim_core.world import RaceResult


@dataclass(frozen=True)
class RaceRun:
    """One race of the series and the measurements beyond its result."""

    index: int
    seed: int
    lanes: tuple[int, int]
    result: RaceResult
    right: tuple[int, ...]  # per kart: opponent lane predictions that came true
    judged: tuple[int, ...]  # per kart: predictions judged
    shortest: tuple[int, ...]  # per kart: fewest ego waypoints of an applied tactical plan (99: none)
    delays: tuple[float, ...] = ()  # [s] per kart: launch delay


def race_once(track: str, names: tuple[str, ...], index: int, seed: int, conditions: str = "paper") -> RaceRun:
    """Race ``names`` on ``track``: kart 0 starts in lane 2 when ``index`` is even, lane 3 when odd."""
    lanes = (2, 3) if index % 2 == 0 else (3, 2)
    metrics = RaceMetrics(len(names))
    spec = RaceSpec(track=track, controllers=names, seed=seed, start_lanes=lanes, conditions=conditions)
    outcome = run_race(spec, on_step=metrics)
    right, judged = [0] * len(names), [0] * len(names)
    for predictor, predicted, checkpoint, lane in metrics.predictions:
        actual = metrics.crossings.get((predicted, checkpoint))
        if actual is not None:
            judged[predictor] += 1
            right[predictor] += int(actual == lane)
    shortest = tuple(metrics.shortest_plan.get(k, 99) for k in range(len(names)))
    return RaceRun(index, seed, lanes, outcome.result, tuple(right), tuple(judged), shortest, outcome.start_delays)


app = typer.Typer(add_completion=False)


@app.command()
def main(
    track: str = typer.Option("complex", help="built-in track name or track JSON"),
    karts: str = typer.Option("mcts-lqng,fixed-lqng", help="two registered controllers, comma separated"),
    races: int = typer.Option(50, min=1),
    first_seed: int = typer.Option(0),
    workers: int = typer.Option(1, min=1, help="races run at a time, each in its own process"),
    conditions: str = typer.Option("paper", help="race conditions drawn from each race's seed: paper or varied"),
) -> None:
    """Race ``karts`` ``races`` times; kart 0 starts in lane 2 in even races and lane 3 in odd ones."""
    names = tuple(karts.split(","))
    if len(names) != 2:
        raise typer.BadParameter("give exactly two controllers")
    # a controller against itself (a control series) is told apart by kart
    labels = names if names[0] != names[1] else tuple(f"{name}#{k}" for k, name in enumerate(names))
    wins = [0, 0]
    finished = [0, 0]
    # per kart: its start lane -> [races from it, wins from it]
    by_lane: list[dict[int, list[int]]] = [{}, {}]
    per_kart: list[dict[str, list[float]]] = [
        {
            "faults": [],
            "illegal": [],
            "illegal_per_step": [],
            "illegal_checkpoint": [],
            "safety": [],
            "passes": [],
            "delta_r": [],
            "delta_v": [],
            "time": [],
        }
        for _ in names
    ]
    right, judged, shortest = [0] * len(names), [0] * len(names), [99] * len(names)
    seeds = [first_seed + i for i in range(races)]
    with ProcessPoolExecutor(workers) as pool:
        mapper = pool.map if workers > 1 else map
        for run in mapper(race_once, [track] * races, [names] * races, range(races), seeds, [conditions] * races):
            result = run.result
            for k in range(len(names)):
                right[k] += run.right[k]
                judged[k] += run.judged[k]
                shortest[k] = min(shortest[k], run.shortest[k])
            if result.winner is not None:
                wins[result.winner] += 1
            for k, lane in enumerate(run.lanes):
                record = by_lane[k].setdefault(lane, [0, 0])
                record[0] += 1
                record[1] += result.winner == k
            for k, kart in enumerate(result.karts):
                stats = per_kart[k]
                finished[k] += kart.finished
                stats["faults"].append(kart.collisions_at_fault)
                stats["illegal"].append(kart.illegal_lane_changes)
                stats["illegal_per_step"].append(kart.illegal_lane_changes_per_step)
                stats["illegal_checkpoint"].append(kart.illegal_lane_changes_checkpoint)
                stats["safety"].append(kart.safety_score)
                stats["passes"].append(kart.passes)
                if kart.delta_r is not None:
                    stats["delta_r"].append(kart.delta_r)
                if kart.delta_v is not None:
                    stats["delta_v"].append(kart.delta_v)
                if kart.finish_time is not None:
                    stats["time"].append(kart.finish_time)
            figures = [
                f"{names[k]} {'DNF' if kart.finish_time is None else f'{kart.finish_time:.2f}s'} "
                f"f{kart.collisions_at_fault} "
                f"i{kart.illegal_lane_changes_per_step}/{kart.illegal_lane_changes_checkpoint} "
                f"p{kart.passes}"
                for k, kart in enumerate(result.karts)
            ]
            launch = f" delays {'/'.join(f'{d:.3f}' for d in run.delays)}" if any(run.delays) else ""
            print(
                f"race {run.index:3d} seed {run.seed} lanes {run.lanes}{launch} winner {result.winner} | "
                + " | ".join(figures),
                flush=True,
            )
    summary: dict[str, object] = {
        "track": track,
        "races": races,
        "conditions": conditions,
        "wins": dict(zip(labels, wins, strict=True)),
        "completion": dict(zip(labels, [f / races for f in finished], strict=True)),
        # each kart's races and wins by its start lane: {label: {lane: [races, wins]}}
        "by_start_lane": {
            label: {str(lane): by_lane[k][lane] for lane in sorted(by_lane[k])} for k, label in enumerate(labels)
        },
    }
    for k, name in enumerate(labels):
        stats = per_kart[k]
        totals: dict[str, float | int | None] = {
            key: round(statistics.fmean(values), 3) if values else None for key, values in stats.items()
        }
        if judged[k]:
            totals["prediction_accuracy"] = round(right[k] / judged[k], 3)
            totals["predictions_judged"] = judged[k]
            totals["fewest_plan_waypoints"] = shortest[k]
        summary[name] = totals
    print(json.dumps(summary))


if __name__ == "__main__":
    app()
