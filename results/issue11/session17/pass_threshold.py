"""How much slower a kart must be before mcts-lqng gets past it: mcts-lqng against fixed-lqng handicapped to a
fraction of its speed targets (``speed_scale``), start lanes alternating (mcts-lqng in lane 2 on even races,
where it comes out of the first corner behind), with the shipped settings and with session 16's (no pace model,
station keeping 0.25 s behind a kart within 1.6 m sideways).

Run from the repo root (prints one line per race, then a JSON summary per setting and scale)::

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session17/pass_threshold.py --track complex --races 6
"""

from __future__ import annotations

import json
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import typer

from controllers.base import Controller
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

SCALES = (1.0, 0.97, 0.95, 0.92, 0.9, 0.85)


def tactical(setting: str) -> Controller:
    """mcts-lqng as shipped (``shipped``) or with session 16's settings (``session16``)."""
    if setting == "shipped":
        return make_controller("mcts-lqng")
    driver = make_controller("mcts-lqng", pace_model=False)
    assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
    driver.tracker = LQNGTracker(
        replace(driver.tracker.params, follow_time=0.25, follow_band=1.6, follow_path_band=0.0)
    )
    return driver


def race(track: str, setting: str, scale: float, index: int) -> dict[str, object]:
    """One race, seed ``index``; mcts-lqng in lane 2 when ``index`` is even."""
    lanes = (2, 3) if index % 2 == 0 else (3, 2)
    spec = RaceSpec(track=track, controllers=("mcts-lqng", "fixed-lqng"), seed=index, start_lanes=lanes)
    karts = run_race(spec, drivers=[tactical(setting), make_controller("fixed-lqng", speed_scale=scale)]).result.karts
    times = [k.finish_time if k.finish_time is not None else float("inf") for k in karts]
    return {
        "setting": setting,
        "scale": scale,
        "seed": index,
        "lane": lanes[0],
        "won": times[0] < times[1],
        "time": [round(t, 2) for t in times],
        "passes": [k.passes for k in karts],
        "faults": [k.collisions_at_fault for k in karts],
        "illegal": [k.illegal_lane_changes for k in karts],
    }


def main(track: str = "complex", races: int = 6, workers: int = 2) -> None:
    """Every setting and scale, ``races`` races each."""
    jobs = [(track, s, f, i) for s in ("shipped", "session16") for f in SCALES for i in range(races)]
    with ProcessPoolExecutor(workers) as pool:
        rows = list(pool.map(race, *zip(*jobs, strict=True)))
    report(rows, ("shipped", "session16"), SCALES)


def report(rows: list[dict[str, object]], settings: tuple[str, ...], scales: tuple[float, ...]) -> None:
    """Print every race, then a JSON summary per setting and scale (mcts-lqng's figures)."""
    for row in rows:
        print(json.dumps(row))
    for setting in settings:
        for scale in scales:
            mine = [r for r in rows if r["setting"] == setting and r["scale"] == scale]
            summary = {
                "setting": setting,
                "scale": scale,
                "races": len(mine),
                "mcts_lqng_wins": sum(bool(r["won"]) for r in mine),
                "lane2_wins": sum(bool(r["won"]) for r in mine if r["lane"] == 2),
                "passes_per_race": sum(r["passes"][0] for r in mine) / len(mine),  # type: ignore[index]
                "faults_per_race": sum(r["faults"][0] for r in mine) / len(mine),  # type: ignore[index]
                "illegal_per_race": sum(r["illegal"][0] for r in mine) / len(mine),  # type: ignore[index]
            }
            print("SUMMARY " + json.dumps(summary))


if __name__ == "__main__":
    typer.run(main)
