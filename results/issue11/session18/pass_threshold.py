"""How much slower a kart must be before mcts-lqng gets past it, with the shipped settings and with session 17's
(no pass commitment, ``hold_gain`` None; passing lanes blended toward the line, ``pass_distance`` 0). The races
are session 17's (``../session17/pass_threshold.py``: fixed-lqng at a fraction ``speed_scale`` of its speed
targets, mcts-lqng in lane 2 on even seeds, where it comes out of the first corner behind).

Run from the repo root (prints one line per race, then a JSON summary per setting and scale)::

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session18/pass_threshold.py --track complex --races 8
"""

from __future__ import annotations

import importlib.util
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import typer

from controllers.base import Controller
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.registry import make_controller
from controllers.tactical.high_level import MCTSPlanner

SCALES = (1.0, 0.97, 0.95, 0.93, 0.92, 0.9, 0.85)
SETTINGS = ("shipped", "session17")
_spec = importlib.util.spec_from_file_location("session17", Path(__file__).parents[1] / "session17/pass_threshold.py")
assert _spec is not None and _spec.loader is not None
session17 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(session17)


def tactical(setting: str) -> Controller:
    """mcts-lqng as shipped (``shipped``) or with session 17's settings (``session17``)."""
    driver = make_controller("mcts-lqng")
    if setting == "shipped":
        return driver
    assert isinstance(driver, HierarchicalController) and isinstance(driver.planner, MCTSPlanner)
    assert isinstance(driver.tracker, LQNGTracker)
    driver.planner.hold_gain = None
    driver.tracker = LQNGTracker(replace(driver.tracker.params, pass_distance=0.0))
    return driver


session17.tactical = tactical  # its race() builds mcts-lqng through this


def race(track: str, setting: str, scale: float, index: int) -> dict[str, object]:
    """Session 17's race (seed ``index``, mcts-lqng in lane 2 when it is even) with this script's settings."""
    return session17.race(track, setting, scale, index)


def main(track: str = "complex", races: int = 8, workers: int = 2) -> None:
    """Every setting and scale, ``races`` races each."""
    jobs = [(track, s, f, i) for s in SETTINGS for f in SCALES for i in range(races)]
    with ProcessPoolExecutor(workers) as pool:
        rows = list(pool.map(race, *zip(*jobs, strict=True)))
    session17.report(rows, SETTINGS, SCALES)


if __name__ == "__main__":
    typer.run(main)
