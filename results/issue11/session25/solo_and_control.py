"""The found setting's pieces alone (solo laps) and against a fixed-lqng given its pace fields (a control).

PYTHONPATH=$PWD .venv/bin/python results/issue11/session25/solo_and_control.py
"""

from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).parent))
import random_search

from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller

PACE = {"grip_steer": 0.982, "lookahead_time": 0.532}
TRAFFIC = {"traffic_lane_tolerance": 0.16, "follow_time": 0.143}
MINIMAL = {"public": {}, "tracker": PACE | TRAFFIC}


def solo(agent: str, fields: dict[str, Any], track: str) -> dict[str, object]:
    """``agent`` alone from lane 2 with its tracker's ``fields`` changed."""
    driver = make_controller(agent)
    assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
    driver.tracker.params = replace(driver.tracker.params, **fields)
    spec = RaceSpec(track=track, controllers=(agent,), seed=0, start_lanes=(2,))
    kart = run_race(spec, drivers=[driver]).result.karts[0]
    return {"solo": agent, "fields": fields, "track": track, "time": kart.finish_time}


def main() -> None:
    jobs: list[tuple[Any, ...]] = []
    for track in ("complex", "oval"):
        for agent in ("mcts-lqng", "fixed-lqng"):
            for fields in ({}, {"lookahead_time": 0.532}, {"grip_steer": 0.982}, PACE, PACE | TRAFFIC):
                jobs.append((solo, agent, fields, track))
    for lane in (2, 3):
        for opponent in ({}, PACE):
            jobs.append((random_search.race, 1, MINIMAL, "complex", lane, 0, opponent))
    with ProcessPoolExecutor(2) as pool:
        futures = [pool.submit(*job) for job in jobs]
        for future in futures:
            row = future.result()
            row.pop("setting", None)
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
