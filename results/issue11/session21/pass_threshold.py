"""How much slower a kart must be before mcts-lqng gets past it from behind: session 20's measurement
(``../session20/pass_threshold.py``, whose driver loop this reuses) with the shipped tracker (``shipped``: Gipps'
safe speed, standoffs 2.3 m on straights and 3.0 m in curves) and session 20's station keeping (``session20``: the
linear rule, 3 m + 0.15 s x speed). mcts-lqng starts in lane 2 of the track against fixed-lqng at a fraction
``speed_scale`` of its speed targets; seeds 0, 2, 4, ...

Run from the repo root (one JSON line per race, then one summary line per setting and scale)::

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session21/pass_threshold.py --starts 16
"""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from pathlib import Path

import typer

from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

_SESSION20 = Path(__file__).parents[1] / "session20" / "pass_threshold.py"
_spec = importlib.util.spec_from_file_location("session20", _SESSION20)
assert _spec is not None and _spec.loader is not None
session20 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(session20)

# session 20's station keeping, on the shipped tracker
SESSION20_STATION = {
    "follow_safe_braking": 0.0,
    "follow_time": 0.15,
    "follow_distance": 3.0,
    "follow_distance_curve": 0.0,
    "follow_brake_gain": 3.0,
}


def race(track: str, setting: str, scale: float, seed: int) -> dict[str, object]:
    """One race from lane 2, seed ``seed``; ``session20``: the tracker with session 20's station keeping."""
    driver = make_controller("mcts-lqng")
    if setting == "session20":
        assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
        driver.tracker = LQNGTracker(replace(driver.tracker.params, **SESSION20_STATION))  # type: ignore[arg-type]
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


session20.SETTINGS = ("shipped", "session20")
session20.SCALES = (1.0, 0.98, 0.97, 0.95, 0.93, 0.92, 0.9)
session20.race = race

if __name__ == "__main__":
    typer.run(session20.main)
