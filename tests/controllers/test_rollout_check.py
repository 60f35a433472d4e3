"""The rollout check races candidate lanes from the observed state: a world placed at the views reproduces them,
no candidate it sends breaks the lane-change rule, it leaves plans alone with nobody ahead, and in the first corner
of complex it finds the inside pass that the search alone never takes, with the kart ahead's own tracker as its
model (the check is a part no registered agent uses: controllers/rollout_check.py says why)."""

from __future__ import annotations

import time
from dataclasses import replace
from functools import partial

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from controllers.base import RaceContext, TimeBoundedPlanner
from controllers.checked_planner import CheckedPlanner, with_rollout_check
from controllers.hierarchical import HierarchicalController
from controllers.lq.presets import fixed_line_tracker, mcts_tracker
from controllers.plan import Plan, Waypoint
from controllers.race import RaceSpec, run_race
from controllers.racing_line import optimise_racing_line
from controllers.registry import make_controller
from controllers.rollout_check import RolloutCheck, RolloutCheckSettings
from controllers.tactical.high_level import MCTSPlanner, lanes_legal
from sim_core import state as st
from sim_core.observation import KartView, Observation, kart_views, observe, place_view
from sim_core.params import PAPER_KART, SimParams
from sim_core.track_io import get_track
from sim_core.world import World

TRACK = get_track("complex")
CONTEXT = RaceContext(TRACK, PAPER_KART, 0, 2, TRACK.lane_change_limit, 0)
LINE_LANES = optimise_racing_line(TRACK, PAPER_KART).checkpoint_lanes
EMPTY = World(TRACK, 1, 2, SimParams(kart=PAPER_KART), sensors=False)
EGO = partial(mcts_tracker, 4)  # mcts-lqng's tracker
RIVAL = partial(fixed_line_tracker, 4)  # the model of the kart ahead: fixed-lqng's tracker


def _checked(depth: int, trust: float = 0.0) -> HierarchicalController:
    """mcts-lqng with its plans checked to ``depth``, the kart ahead modelled as fixed-lqng (gated at ``trust``)."""
    driver = make_controller("mcts-lqng")
    assert isinstance(driver, HierarchicalController)
    return with_rollout_check(driver, RolloutCheckSettings(depth=depth, trust_miss=trust), RIVAL)


def _raced_world(seconds: float) -> World:
    """The world of a race of two fixed-lqng karts from lanes 2 and 3, stopped after ``seconds``."""
    raced: list[World] = []
    spec = RaceSpec("complex", ("fixed-lqng", "fixed-lqng"), start_lanes=(2, 3), time_limit=seconds)
    run_race(spec, on_step=lambda world, drivers, step: raced.append(world) if not raced else None)
    return raced[0]


def test_a_world_placed_at_the_views_shows_the_same_karts() -> None:
    source = _raced_world(8.0)  # 8 s in: mid-corner, counters and lanes away from their start values
    views = kart_views(source, 0)
    copy = World(TRACK, 1, 2, SimParams(kart=PAPER_KART), sensors=False)
    for slot, view in enumerate(views):
        place_view(copy, 0, slot, view, steer=0.3)
    for before, after in zip(views, kart_views(copy, 0), strict=True):
        for name in ("x", "y", "heading", "speed", "progress", "lateral", "wear", "crossing_time"):
            # the pose goes through (progress, offset) and back: equal to well under a millimetre
            assert getattr(after, name) == pytest.approx(getattr(before, name), abs=1e-4), name
        for name in ("checkpoints_passed", "lane", "lane_changes", "lane_now", "lane_changes_now", "finished"):
            assert getattr(after, name) == getattr(before, name), name
    # the slip that a steady steer of 0.3 holds: tan(slip) = tan(0.3 * max steer) / 2
    assert np.tan(copy.fstate[0, 0, st.F_SLIP]) == pytest.approx(0.5 * np.tan(0.3 * PAPER_KART.max_steer_angle))


def _check(depth: int = 2, exhaustive: bool = True) -> RolloutCheck:
    check = RolloutCheck(RolloutCheckSettings(depth=depth, exhaustive=exhaustive), EGO, RIVAL)
    check.reset(CONTEXT)
    return check


def _first_corner() -> tuple[Observation, Plan, RolloutCheck, KartView]:
    """6 s into a race of two fixed-lqng karts (the first corner, the karts close: the rival in reach): kart 0's
    observation, a plan on the racing line's lanes (the other kart predicted in lane 3), a depth-3 check and the
    kart it races."""
    observation = observe(_raced_world(6.0), 0)[0]
    first = observation.me.checkpoints_passed + 1
    plan = _plan(first, [LINE_LANES[(first + i) % TRACK.n_checkpoints] for i in range(6)])
    plan = replace(plan, waypoints={**plan.waypoints, 1: _plan(first, [3, 3, 3, 3, 3, 3]).waypoints[0]})
    check = _check(depth=3)
    rival = check.rival(observation)
    assert rival is not None
    return observation, plan, check, rival


def _plan(first: int, lanes: list[int]) -> Plan:
    waypoints = []
    for i, lane in enumerate(lanes):
        point = TRACK.lane_point((first + i) % TRACK.n_checkpoints, lane)
        waypoints.append(Waypoint(first + i, lane, (float(point[0]), float(point[1])), 12.0, 0.9 * i))
    return Plan(0, first - 1, {0: tuple(waypoints)}, 10, 1, 0.0)


@settings(max_examples=200, deadline=None)
@given(
    first=hs.integers(1, 3 * TRACK.n_checkpoints - 6),
    lanes=hs.lists(hs.integers(1, 4), min_size=6, max_size=6),
    start_lane=hs.integers(1, 4),
    start_count=hs.integers(0, 4),
    depth=hs.integers(1, 3),
    exhaustive=hs.booleans(),
)
def test_no_candidate_breaks_the_lane_change_rule(
    first: int, lanes: list[int], start_lane: int, start_count: int, depth: int, exhaustive: bool
) -> None:
    check = _check(depth, exhaustive)
    me = replace(kart_views(EMPTY, 0)[0], checkpoints_passed=first - 1, lane=start_lane, lane_changes=start_count)
    plan = _plan(first, lanes)
    limit = TRACK.lane_change_limit
    candidates = check.candidates(plan, me, LINE_LANES, limit)
    searched = tuple(lanes[1 : 1 + depth])
    assert candidates[0] == searched  # the search's own lanes come first, legal or not (it only sends legal ones)
    assert len(set(candidates)) == len(candidates)
    for lanes_tried in candidates[1:]:
        waypoints = check.with_lanes(plan.ego_waypoints, lanes_tried)
        assert lanes_legal(TRACK, start_lane, start_count, list(waypoints), limit)
        # only the window changes: the committed first waypoint and the tail are the search's
        assert waypoints[0] == plan.ego_waypoints[0]
        assert waypoints[1 + depth :] == plan.ego_waypoints[1 + depth :]
        assert tuple(w.lane for w in waypoints[1 : 1 + depth]) == lanes_tried


def test_an_exhaustive_check_tries_every_legal_sequence() -> None:
    check = _check(depth=2)
    me = replace(kart_views(EMPTY, 0)[0], checkpoints_passed=5, lane=4, lane_changes=0)
    # checkpoints 6-8 lie in the first corner, where the lane-change rule sets no limit: all 16 sequences
    candidates = check.candidates(_plan(6, [4, 3, 3, 3]), me, LINE_LANES, TRACK.lane_change_limit)
    assert sorted(candidates) == sorted((a, b) for a in range(1, 5) for b in range(1, 5))


def test_with_nobody_ahead_the_plan_is_sent_as_searched() -> None:
    world = World(TRACK, 1, 2, SimParams(kart=PAPER_KART), sensors=False)
    world.reset(start_lanes=(2, 3))
    world.place_kart(0, 1, s=200.0, d=0.0)  # far ahead: out of reach
    observation = observe(world, 0)[0]
    check = _check()
    plan = _plan(1, [2, 2, 3, 4, 4])
    assert check.check(observation, plan, LINE_LANES, TRACK.lane_change_limit) is plan
    assert (check.counts.plans, check.counts.checked, check.counts.rollouts) == (1, 0, 0)


def test_the_checked_planner_holds_the_inside_of_the_first_corner_and_passes() -> None:
    """From lane 2 of complex, the kart in lane 3 takes the inside of the 270-degree first corner. mcts-lqng as
    registered follows the line out to lane 3 behind it (and loses every lane-2 start); with the check it stays on
    the inside through checkpoints 7-9 and leads at checkpoint 10."""
    crossings: dict[tuple[int, int], tuple[int, int]] = {}

    def record(world: World, drivers: object, step: int) -> None:
        for k in (0, 1):
            key = (k, int(world.istate[0, k, st.I_CP_PASSED]))
            crossings.setdefault(key, (int(world.istate[0, k, st.I_LANE]), step))

    spec = RaceSpec("complex", ("mcts-lqng", "fixed-lqng"), seed=0, start_lanes=(2, 3), time_limit=11.5)
    checked = _checked(depth=3, trust=0.15)
    assert isinstance(checked.planner, CheckedPlanner)
    run_race(spec, drivers=[checked, make_controller("fixed-lqng")], on_step=record)
    inside = [crossings[(0, c)][0] for c in (7, 8, 9)]
    assert min(inside) >= 3 and 4 in inside, inside  # on the inside half, in lane 4 at one crossing at least
    assert crossings[(0, 10)][1] < crossings[(1, 10)][1]  # the ego crossed checkpoint 10 first
    result_faults = checked.planner.check.counts  # type: ignore[attr-defined]
    assert result_faults.changed >= 1

    crossings.clear()
    plain = make_controller("mcts-lqng")
    run_race(spec, drivers=[plain, make_controller("fixed-lqng")], on_step=record)
    assert crossings[(0, 10)][1] > crossings[(1, 10)][1]  # without the check it is still behind there


def test_a_search_with_the_check_is_the_registered_planner_underneath() -> None:
    checked = _checked(depth=2)
    plain = make_controller("mcts-lqng")
    assert isinstance(checked.planner, CheckedPlanner)
    assert isinstance(plain.planner, MCTSPlanner)  # type: ignore[attr-defined]
    assert checked.planner.check.settings.depth == 2
    assert checked.planner.inner.iterations == plain.planner.iterations  # type: ignore[attr-defined]


def test_the_tree_of_rollouts_scores_every_candidate_as_racing_it_alone() -> None:
    """Candidates sharing their first lanes are raced once up to where they part (the world copied there): each
    score is the number racing that candidate from the start gives, to the last bit, in fewer steps."""
    observation, plan, check, rival = _first_corner()
    target = plan.ego_waypoints[3].checkpoint + check.settings.settle
    candidates = [(a, b, c) for a in (2, 4) for b in (3, 4) for c in (1, 4)]
    tree = check.scores(observation, rival, plan, target, candidates)
    tree_steps = check.counts.steps
    alone = {lanes: check.score(observation, rival, check.with_lanes_plan(plan, lanes), target) for lanes in candidates}
    assert list(tree) == candidates
    assert tree == alone
    assert len(set(alone.values())) > 1  # the lanes matter here: the test compares different races
    assert tree_steps < 0.9 * (check.counts.steps - tree_steps)


def _gated_race(opponent: str, seconds: float, trust: float = 0.15) -> tuple[RolloutCheck, list[float]]:
    """A lane-2 start on complex of mcts-lqng (a depth-1 check gated at ``trust``) against ``opponent``, stopped
    after ``seconds``: the check and the finish-line-free race's last positions (x, y per kart)."""
    spec = RaceSpec("complex", ("mcts-lqng", opponent), seed=0, start_lanes=(2, 3), time_limit=seconds)
    checked = _checked(depth=1, trust=trust)
    end: list[float] = []

    def last(world: World, drivers: object, step: int) -> None:
        end[:] = [float(v) for v in world.positions[0].ravel()]

    run_race(spec, drivers=[checked, make_controller(opponent)], on_step=last)
    return checked.planner.check, end  # type: ignore[attr-defined]


def test_the_gate_trusts_a_line_follower_and_not_a_kart_on_a_line_of_its_own() -> None:
    """The follower (fixed-lqng's planner and tracker) predicts fixed-lqng a second ahead to a few centimetres,
    so the check races it; a lane follower, which keeps its start lane, it misses by far more, and the check
    leaves every plan against it alone."""
    check, _ = _gated_race("fixed-lqng", 10.0)
    misses = [miss for _, kart, miss in check.counts.misses if kart == 1]
    assert len(misses) >= 8  # one per plan after the first
    assert float(np.median(misses)) < 0.05 and check.trusts(1)
    assert check.counts.checked >= 5 and check.counts.untrusted == 1  # only the first plan: nothing measured yet

    check, _ = _gated_race("lane-follower", 10.0)
    misses = [miss for _, kart, miss in check.counts.misses if kart == 1]
    assert float(np.median(misses)) > 0.3 and not check.trusts(1)
    assert check.counts.checked == 0 and check.counts.untrusted >= 5


def test_a_kart_the_gate_does_not_trust_races_as_without_the_check() -> None:
    """Against a kart it does not trust the check changes nothing: the race is the search's alone, to the bit."""
    _, gated = _gated_race("lane-follower", 10.0)
    spec = RaceSpec("complex", ("mcts-lqng", "lane-follower"), seed=0, start_lanes=(2, 3), time_limit=10.0)
    plain: list[float] = []
    run_race(
        spec,
        drivers=[make_controller("mcts-lqng"), make_controller("lane-follower")],
        on_step=lambda world, drivers, step: plain.__setitem__(
            slice(None), [float(v) for v in world.positions[0].ravel()]
        ),
    )
    assert gated == plain


def test_the_gate_races_nobody_before_it_has_measured_them() -> None:
    """At the start nothing is measured: side by side on the grid the plan is sent as searched, no rollout raced;
    without the gate (trust 0) the same kart is raced at once."""
    world = World(TRACK, 1, 2, SimParams(kart=PAPER_KART), sensors=False)
    world.reset(start_lanes=(2, 3))
    observation = observe(world, 0)[0]
    plan = _plan(1, [2, 2, 3, 4, 4])
    plan = replace(plan, waypoints={**plan.waypoints, 1: _plan(1, [3, 3, 3, 3, 3]).waypoints[0]})
    gated = RolloutCheck(RolloutCheckSettings(depth=2, trust_miss=0.15), EGO, RIVAL)
    gated.reset(CONTEXT)
    assert gated.check(observation, plan, LINE_LANES, TRACK.lane_change_limit) is plan
    assert (gated.counts.untrusted, gated.counts.checked, gated.counts.rollouts) == (1, 0, 0)
    ungated = _check(depth=2)
    ungated.check(observation, plan, LINE_LANES, TRACK.lane_change_limit)
    assert ungated.counts.checked == 1 and ungated.counts.rollouts > 1
    with pytest.raises(ValueError):
        RolloutCheckSettings(trust_miss=-0.1)


def test_past_its_deadline_the_check_races_only_the_search_s_own_lanes() -> None:
    """A live host's budget spent (the deadline passed before the check began): of the candidates only the search's
    own lanes are raced, to the same score as without a deadline, and the rest are counted as cut; the checked
    planner then sends the search's plan."""
    observation, plan, check, rival = _first_corner()
    target = plan.ego_waypoints[3].checkpoint + check.settings.settle
    candidates = check.candidates(plan, observation.me, LINE_LANES, TRACK.lane_change_limit)
    whole = check.scores(observation, rival, plan, target, candidates)
    assert len(whole) == len(candidates) > 8 and check.counts.cut == 0
    check.deadline = time.perf_counter() - 1.0
    cut = check.scores(observation, rival, plan, target, candidates)
    assert cut == {candidates[0]: whole[candidates[0]]}
    assert check.counts.cut == len(candidates) - 1
    assert check.check(observation, plan, LINE_LANES, TRACK.lane_change_limit) is plan


def test_the_checked_planner_keeps_to_a_live_budget() -> None:
    """With ``plan_budget_s`` set (a live host's :class:`TimeBoundedPlanner` capability) the check stops racing new
    branches once the budget is spent; without it (headless) every candidate is raced."""
    observation = observe(_raced_world(6.0), 0)[0]
    for budget, cut in ((None, False), (0.0, True)):
        driver = _checked(depth=3)  # the gate off: raced at once
        planner = driver.planner  # type: ignore[attr-defined]
        assert isinstance(planner, TimeBoundedPlanner) and planner.plan_budget_s is None
        planner.plan_budget_s = budget
        planner.reset(CONTEXT)
        planner.plan(observation)
        counts = planner.check.counts
        assert counts.checked == 1 and (counts.cut > 0) == cut, counts


def test_a_delayed_plan_is_checked_from_where_the_karts_will_be_when_it_arrives() -> None:
    """``ahead`` races the ego and the kart ahead on the plan sent before for the delay: the same karts (by index),
    each on by about its speed times the delay, and the time moved on; no delay, the same observation."""
    observation, plan, check, rival = _first_corner()
    later = check.ahead(observation, rival, plan, 15)
    assert later.time == pytest.approx(observation.time + 0.3) and later.ego == observation.ego
    assert [k.index for k in later.karts] == [k.index for k in observation.karts]
    for before, after in zip(observation.karts, later.karts, strict=True):
        assert TRACK.gap(before.progress, after.progress) == pytest.approx(0.3 * before.speed, rel=0.2)
    same = check.ahead(observation, rival, plan, 0)
    assert same.me.progress == pytest.approx(observation.me.progress, abs=1e-6)
