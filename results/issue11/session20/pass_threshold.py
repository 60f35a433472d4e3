"""How much slower a kart must be before mcts-lqng gets past it from behind, with the pass on prediction (shipped,
``LQNGParams.pass_on_prediction``) and without it (session 19's tracker). mcts-lqng starts in lane 2 of `complex`
(where it comes out of the first corner about 0.5 s behind) against fixed-lqng at a fraction ``speed_scale`` of
its speed targets; seeds 0, 2, 4, ...

Run from the repo root (one JSON line per race, then one summary line per setting and scale)::

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session20/pass_threshold.py --starts 16
"""

from __future__ import annotations

import json
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import typer

from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

SCALES = (0.97, 0.95, 0.93, 0.92, 0.9)
SETTINGS = ("shipped", "session19")


def race(track: str, setting: str, scale: float, seed: int) -> dict[str, object]:
    """One race from lane 2, seed ``seed``; ``session19``: the tracker without the pass on prediction."""
    driver = make_controller("mcts-lqng")
    if setting == "session19":
        assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
        driver.tracker = LQNGTracker(replace(driver.tracker.params, pass_on_prediction=False))
    spec = RaceSpec(track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=seed, start_lanes=(2, 3))
    karts = run_race(spec, drivers=[driver, make_controller("fixed-lqng", speed_scale=scale)]).result.karts
    times = [k.finish_time if k.finish_time is not None else float("inf") for k in karts]
    return {
        "setting": setting,
        "scale": scale,
        "seed": seed,
        "won": times[0] < times[1],
        "margin": round(times[0] - times[1], 2),
        "passes": [k.passes for k in karts],
        "faults": [k.collisions_at_fault for k in karts],
        "illegal": [k.illegal_lane_changes for k in karts],
    }


def main(track: str = "complex", starts: int = 16, workers: int = 2) -> None:
    """Every setting and scale, ``starts`` races from lane 2 each."""
    jobs = [(track, s, f, 2 * i) for s in SETTINGS for f in SCALES for i in range(starts)]
    with ProcessPoolExecutor(workers) as pool:
        rows = list(pool.map(race, *zip(*jobs, strict=True)))
    for row in rows:
        print(json.dumps(row))
    for setting in SETTINGS:
        for scale in SCALES:
            mine = [r for r in rows if r["setting"] == setting and r["scale"] == scale]
            summary = {
                "setting": setting,
                "scale": scale,
                "starts": len(mine),
                "wins": sum(bool(r["won"]) for r in mine),
                "passes": sum(r["passes"][0] for r in mine),  # type: ignore[index]
                "faults": [sum(r["faults"][k] for r in mine) for k in range(2)],  # type: ignore[index]
                "illegal": [sum(r["illegal"][k] for r in mine) for k in range(2)],  # type: ignore[index]
            }
            print("SUMMARY " + json.dumps(summary))


if __name__ == "__main__":
    typer.run(main)
