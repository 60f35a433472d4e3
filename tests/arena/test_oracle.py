"""The oracle bound (arena.oracle): its candidates, and that its search passes where lanes decide."""

from __future__ import annotations

from dataclasses import replace

import pytest

from arena.oracle import OraclePlanner, OracleSettings, oracle_driver
from arena.scenario_setups import attempt_specs, judge
from arena.scenario_spec import Cell, load_scenario
from controllers.base import RaceContext
from controllers.fixed_line import FixedLinePlanner
from controllers.race import run_race
from controllers.registry import make_agent
from sim_core.observation import observe
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track
from sim_core.world import World


def test_the_candidates_are_the_base_plan_and_each_lane_held_then_the_base_plan() -> None:
    track = get_track("oval")
    planner = OraclePlanner(FixedLinePlanner(), OracleSettings(hold_checkpoints=3))
    planner.reset(RaceContext(track, PAPER_KART, 0, 2, track.lane_change_limit, 0))
    observation = observe(World(track, 1, 2), 0)[0]
    base = planner.plan(observation)  # no race attached: the base plan
    plans = planner.candidates(observation, base)
    line = [w.lane for w in plans[0].ego_waypoints]
    assert plans[0] is base
    held = [[w.lane for w in p.ego_waypoints] for p in plans[1:]]
    assert held and all(len(set(lanes[:3])) == 1 and lanes[3:] == line[3:] for lanes in held)
    # one candidate per lane that differs from the line somewhere: no duplicate of the line
    assert len({lanes[0] for lanes in held}) == len(held) and all(lanes != line for lanes in held)


@pytest.mark.slow
def test_the_oracle_passes_a_slow_kart_that_holds_its_lane_by_the_rules() -> None:
    scenario = replace(load_scenario("overtake-straight"), laps=1)
    (spec,) = attempt_specs(scenario, Cell(scenario.name, "oval", "fixed-lqng", "lane-follower", 0.8), 1, seed=2)
    ego, hook = oracle_driver(OracleSettings(lookahead_s=2.0, base="mcts-lqng:iterations=200"))
    outcome = run_race(spec, on_step=hook, drivers=[ego, make_agent(spec.controllers[1])])
    attempt = judge("overtake", outcome, hook.first_pass_step)
    assert attempt.success and attempt.collisions_at_fault == 0 and attempt.illegal_lane_changes == 0
    assert hook.planner.searches > 5  # it raced its candidates forward at every plan
