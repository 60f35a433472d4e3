"""One tournament race: E2E with the MCTS planner in the background drives exactly as without it (the planner
only gives the referee targets), and only then has Δr and Δv, as the paper measured them."""

from __future__ import annotations

from dataclasses import replace

from arena.race import RaceJob, run_job, with_background_planner
from controllers.base import PlanningDriver


def test_a_background_planner_measures_e2e_without_changing_how_it_drives() -> None:
    job = RaceJob(0, "oval", ("e2e", "lane-follower"), seed=11, start_lanes=(2, 3), time_limit=12.0)
    plain = run_job(job, record=True)
    planned = run_job(replace(job, background_planners=("e2e",)), record=True)
    assert plain.replay is not None and planned.replay is not None
    assert planned.replay["poses"] == plain.replay["poses"]  # the same inputs, step for step
    assert plain.result.karts[0].delta_r is None
    e2e = planned.result.karts[0]
    assert e2e.delta_r is not None and e2e.delta_v is not None and e2e.delta_r >= 0.0
    assert planned.result.karts[1].delta_r == plain.result.karts[1].delta_r
    assert planned.replay["plans"] and all(p["kart"] == 0 for p in planned.replay["plans"])


def test_an_agent_that_plans_keeps_its_own_planner() -> None:
    driver = with_background_planner("mcts-lqng")
    assert isinstance(driver, PlanningDriver) and type(driver.tracker).__name__ == "LQNGTracker"
