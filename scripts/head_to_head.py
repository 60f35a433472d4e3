"""A series of headless races between two registered controllers, start lanes alternating, with the paper's
per-race figures summed up. Prints one line per race and a JSON summary as the last line.

    .venv/bin/python scripts/head_to_head.py --track complex --karts mcts-lqng,fixed-lqng --races 50
"""

from __future__ import annotations

import json
import statistics

import typer

from controllers.race import RaceSpec, run_race
from controllers.race_metrics import RaceMetrics

app = typer.Typer(add_completion=False)


@app.command()
def main(
    track: str = typer.Option("complex", help="built-in track name or track JSON"),
    karts: str = typer.Option("mcts-lqng,fixed-lqng", help="two registered controllers, comma separated"),
    races: int = typer.Option(50, min=1),
    first_seed: int = typer.Option(0),
) -> None:
    """Race ``karts`` ``races`` times; kart 0 starts in lane 2 in even races and lane 3 in odd ones."""
    names = tuple(karts.split(","))
    if len(names) != 2:
        raise typer.BadParameter("give exactly two controllers")
    wins = [0, 0]
    finished = [0, 0]
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
    for i in range(races):
        seed = first_seed + i
        lanes = (2, 3) if i % 2 == 0 else (3, 2)
        metrics = RaceMetrics(len(names))
        outcome = run_race(RaceSpec(track=track, controllers=names, seed=seed, start_lanes=lanes), on_step=metrics)
        result = outcome.result
        for predictor, predicted, checkpoint, lane in metrics.predictions:
            actual = metrics.crossings.get((predicted, checkpoint))
            if actual is not None:
                judged[predictor] += 1
                right[predictor] += int(actual == lane)
        for planner, fewest in metrics.shortest_plan.items():
            shortest[planner] = min(shortest[planner], fewest)
        if result.winner is not None:
            wins[result.winner] += 1
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
            f"{names[k]} {kart.finish_time or float('nan'):.2f}s "
            f"f{kart.collisions_at_fault} i{kart.illegal_lane_changes_per_step}/{kart.illegal_lane_changes_checkpoint} "
            f"p{kart.passes}"
            for k, kart in enumerate(result.karts)
        ]
        print(f"race {i:3d} seed {seed} lanes {lanes} winner {result.winner} | " + " | ".join(figures), flush=True)
    summary: dict[str, object] = {
        "track": track,
        "races": races,
        "wins": dict(zip(names, wins, strict=True)),
        "completion": dict(zip(names, [f / races for f in finished], strict=True)),
    }
    for k, name in enumerate(names):
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
