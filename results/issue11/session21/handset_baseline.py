"""Does the original's baseline line explain its start-lane pattern? Races on ``complex`` from both start lanes
with fixed-lqng on the original's hand-set lanes (``controllers.racing_line.handset_line``: a spline through the
``optimalLane`` lane at each checkpoint) instead of the computed racing line, against mcts-lqng and against the
shipped fixed-lqng. Our simulator is deterministic up to the planner's seed, so each start is one race.

Run from the repo root (one JSON line per race)::

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session21/handset_baseline.py
"""

from __future__ import annotations

import json

from controllers.base import RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.race import RaceSpec, run_race
from controllers.racing_line import handset_line
from controllers.registry import make_controller


def handset_fixed() -> HierarchicalController:
    """fixed-lqng whose planner and tracker use the hand-set line."""
    driver = make_controller("fixed-lqng")
    assert isinstance(driver, HierarchicalController)
    planner, tracker = driver.planner, driver.tracker
    planner_reset, tracker_reset = planner.reset, tracker.reset

    def reset_planner(context: RaceContext) -> None:
        planner_reset(context)
        planner._line = handset_line(context.track, context.kart)  # type: ignore[attr-defined]

    def reset_tracker(context: RaceContext) -> None:
        tracker_reset(context)
        tracker._line = handset_line(context.track, context.kart)  # type: ignore[attr-defined]

    planner.reset = reset_planner  # type: ignore[method-assign]
    tracker.reset = reset_tracker  # type: ignore[method-assign]
    return driver


def main() -> None:
    for first in ("mcts-lqng", "fixed-lqng", "fixed-handset"):
        for lanes in ((2, 3), (3, 2)):
            drivers = [handset_fixed() if first == "fixed-handset" else make_controller(first), handset_fixed()]
            spec = RaceSpec(track="complex", controllers=(first, "fixed-lqng"), seed=0, start_lanes=lanes)
            karts = run_race(spec, drivers=drivers).result.karts
            print(
                json.dumps(
                    {
                        "karts": [first, "fixed-handset"],
                        "lanes": lanes,
                        "times": [k.finish_time for k in karts],
                        "faults": [k.collisions_at_fault for k in karts],
                        "illegal": [k.illegal_lane_changes for k in karts],
                    }
                ),
                flush=True,
            )


if __name__ == "__main__":
    main()
