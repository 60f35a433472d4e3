"""The LQNG tracker's traffic rules (controllers/lq/traffic.py), each alone on placed karts with hand-checked
numbers: station keeping (linear and Gipps), yielding, pass detection, the lane-rule guard, the alongside
discipline, the steer-rate limit, and how the tracker composes them; and fixed-lqng under those rules behind two
slower karts side by side, where the paper's fixed-lqng runs into one."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from controllers.base import Controller, RaceContext
from controllers.fixed_line import FixedLinePlanner
from controllers.hierarchical import HierarchicalController
from controllers.lq.presets import MCTS_TRACKING, MCTS_TRAFFIC, fixed_line_tracker, mcts_tracker
from controllers.lq.tracker import LQNGTracker, within
from controllers.lq.traffic import (
    AlongsideDiscipline,
    LaneRuleGuard,
    PassDetector,
    StationKeeping,
    SteerRateLimit,
    TrafficScene,
    Yield,
)
from controllers.plan import Plan, Waypoint
from controllers.race import Placement, RaceSpec, run_race
from controllers.racing_line import optimise_racing_line
from controllers.registry import FixedLQNGParams, make_agent
from sim_core import state as st
from sim_core.observation import KartView, observe
from sim_core.params import DT, PAPER_KART, SimParams
from sim_core.track import Track
from sim_core.track_io import get_track
from sim_core.world import World

OVAL = get_track("oval")
BACK_STRAIGHT = 11  # the oval's back straight runs from checkpoint 10 to 16
CURVE = 8


def _preset(kind: type) -> object:
    """The ``mcts-lqng`` preset's rule of type ``kind``."""
    return next(rule for rule in MCTS_TRAFFIC if isinstance(rule, kind))


def _scene(
    me: KartView, others: list[KartView], plan: Plan | None = None, track: Track = OVAL, upcoming: int = 2
) -> TrafficScene:
    """The scene the rules see, the ego's next two waypoints in lane ``upcoming`` unless the plan says."""
    line = optimise_racing_line(track, PAPER_KART)
    first = me.checkpoints_passed + 1
    points = [track.lane_point(first + k, upcoming) for k in range(2)]
    ahead = [Waypoint(first + k, upcoming, (float(p[0]), float(p[1])), 15.0, 0.0) for k, p in enumerate(points)]
    if plan is not None:
        ahead = [w for w in plan.waypoints.get(me.index, ()) if w.checkpoint > me.checkpoints_passed][:2] or ahead
    return TrafficScene(track, me, others, plan, line, (ahead[0], ahead[-1]), track.lane_change_limit, 1.0, 0.45, 3.0)


def _kart(index: int, x: float, y: float, speed: float, passed: int = BACK_STRAIGHT) -> KartView:
    """A kart placed on a plane, heading along +x (lateral offset = y)."""
    return KartView(index, x, y, 0.0, speed, x, y, 0.25, passed, 2, 0, 0.0, speed, 0.25, False)


def _on_oval(index: int, progress: float, lateral: float, passed: int, speed: float = 14.0) -> KartView:
    """A kart on the oval at ``progress`` [m] along the centre line and ``lateral`` [m] from it."""
    point, tangent = OVAL.point_at(progress)
    x, y = float(point[0] - tangent[1] * lateral), float(point[1] + tangent[0] * lateral)
    heading = math.atan2(float(tangent[1]), float(tangent[0]))
    return KartView(index, x, y, heading, speed, progress, lateral, 0.25, passed, 2, 0, 0.0, speed, 0.25, False)


def test_linear_station_keeping_holds_behind_a_kart_in_its_path_and_not_beside_it() -> None:
    """The linear rule (3 m + 0.15 s x speed, gain 1/s) behind a slower kart within 1.0 m of it sideways, or within
    1.2 m of where it steers; pulling out to pass, 1.3 m aside and steering 2.5 m away, it is free to go by."""
    rule = StationKeeping.linear(distance=3.0, time=0.15, band=1.0, path_band=1.2, gain=1.0)
    me = _kart(0, 0.0, 0.0, 15.0)
    gap = 3.0 + 0.15 * me.speed
    slower = 13.0

    def limit(other: KartView, aim_offset: float) -> float:
        return rule.speed_limit(_scene(me, [other]), aim_offset)

    assert limit(_kart(1, gap, 0.5, slower), aim_offset=2.5) == slower
    beside_the_path = _kart(1, gap, 1.3, slower)
    assert limit(beside_the_path, aim_offset=-1.2) == math.inf  # pulling out the other way
    assert limit(beside_the_path, aim_offset=1.0) == slower  # cutting in behind it
    assert limit(_kart(1, gap - 1.0, 0.5, slower), aim_offset=0.0) == slower - 1.0
    assert limit(_kart(1, 1.0, 0.2, slower), aim_offset=0.0) == math.inf  # alongside: lane discipline, not braking


def test_the_safe_speed_is_gipps_hand_checked_and_stops_short_of_a_kart_braking_ahead() -> None:
    """mcts-lqng's station keeping: Gipps' safe speed with b = 6 m/s^2, tau = 0.05 s, a 2.3 m standoff on straights
    and 3.0 m in curves. Behind a standing kart 5.3 m (6.0 m in a curve) ahead, v = sqrt(0.3^2 + 2 * 6 * 3) - 0.3 =
    5.7075 m/s. The oracle: a kart at the safe speed that brakes at b after tau stops, with the kart ahead braking at
    b from its speed, no closer than the standoff."""
    rule = _preset(StationKeeping)
    assert isinstance(rule, StationKeeping) and rule.kind == "gipps"
    assert (rule.safe_braking, rule.time, rule.distance, rule.distance_curve) == (6.0, 0.05, 2.3, 3.0)
    assert OVAL.section_is_straight(BACK_STRAIGHT) and not OVAL.section_is_straight(CURVE)

    def limit(ahead: float, other_speed: float, passed: int = BACK_STRAIGHT) -> float:
        me = _kart(0, 0.0, 0.0, 9.0, passed)
        return rule.speed_limit(_scene(me, [_kart(1, ahead, 0.0, other_speed, passed)]), 0.0)

    expected = math.sqrt(0.3**2 + 2 * 6.0 * 3.0) - 0.3
    assert limit(5.3, 0.0) == pytest.approx(expected)
    assert limit(6.0, 0.0, passed=CURVE) == pytest.approx(expected)
    assert limit(2.3, 0.0) == 0.0  # at the standoff
    b, tau, standoff = 6.0, 0.05, 2.3
    for ahead, other_speed in ((4.0, 14.0), (8.0, 10.0), (3.0, 5.0), (12.0, 2.0)):
        v = limit(ahead, other_speed)
        follower_stop = v * tau + v * v / (2 * b)
        leader_stop = ahead + other_speed**2 / (2 * b)
        assert leader_stop - follower_stop == pytest.approx(standoff)
        # the gap along the way never falls below the standoff (both braking at b, the follower after tau)
        t = np.linspace(0.0, tau + v / b, 400)
        follower = np.where(t < tau, v * t, v * tau + v * (t - tau) - 0.5 * b * (t - tau) ** 2)
        leader_t = np.minimum(t, other_speed / b)
        leader = ahead + other_speed * leader_t - 0.5 * b * leader_t**2
        assert (leader - follower).min() >= standoff - 1e-9


def test_it_yields_to_a_faster_kart_cutting_across_from_alongside() -> None:
    """mcts-lqng brakes at once (a limit 0.6 m/s under its own speed) for a kart 2 m/s or more faster, alongside or
    less than the 2.3 m standoff ahead, that will be within 1.0 m sideways within 0.4 s: 2.0 m to its left and 0.5 m
    ahead at 12 m/s, heading 15 degrees across toward it (3.1 m/s sideways, 1.24 m in 0.4 s). Not when that kart
    holds its line, is not faster by the margin, or is further back than the alongside reach. (Such a kart cuts in
    a body length ahead, and the contact is the follower's fault.)"""
    rule = _preset(Yield)
    assert rule == Yield(speed_margin=2.0, drop=0.6, reach=2.5, ahead=2.3, band=1.0, predict_time=0.4)
    s = float(OVAL.checkpoint_s[BACK_STRAIGHT]) + 5.0
    me = _on_oval(0, s, 0.0, BACK_STRAIGHT, speed=9.0)
    across = math.radians(15.0)

    def limit(other: KartView) -> float:
        assert isinstance(rule, Yield)
        return rule.speed_limit(_scene(me, [other]), 0.0)

    cutting_in = _on_oval(1, s + 0.5, 2.0, BACK_STRAIGHT, speed=12.0)
    cutting_in = replace(cutting_in, heading=cutting_in.heading - across)
    assert limit(cutting_in) == pytest.approx(9.0 - 0.6)
    assert limit(_on_oval(1, s + 0.5, 2.0, BACK_STRAIGHT, speed=12.0)) == math.inf  # holding its line
    assert limit(replace(cutting_in, speed=10.5)) == math.inf  # not faster by the margin
    behind = _on_oval(1, s - 3.0, 2.0, BACK_STRAIGHT, speed=12.0)
    assert limit(replace(behind, heading=behind.heading - across)) == math.inf


def _plan(first: int, lanes: dict[int, tuple[int, ...]]) -> Plan:
    """A plan from checkpoint ``first`` with each kart's lanes there and after."""
    waypoints = {}
    for kart, kart_lanes in lanes.items():
        points = [OVAL.lane_point(first + k, lane) for k, lane in enumerate(kart_lanes)]
        waypoints[kart] = tuple(
            Waypoint(first + k, lane, (float(p[0]), float(p[1])), 15.0, 0.0)
            for k, (lane, p) in enumerate(zip(kart_lanes, points, strict=True))
        )
    return Plan(0, first - 1, waypoints, 1, 1, 0.0)


def test_a_pass_planned_on_a_straight_is_driven_in_its_lane() -> None:
    """mcts-lqng drives its planned lanes exactly while passing: on a straight, behind a kart within 10 m that
    drives under the racing line's speed there, with the next planned lane 1.5 m or more clear of it sideways. Not
    when the planned lane is in the other kart's wake, the kart is further ahead, behind, or at the line's pace
    (behind such a kart, driven exactly, it crossed lanes early into the next curve: an illegal lane change), or
    on a curve."""
    rule = _preset(PassDetector)
    assert isinstance(rule, PassDetector) and (rule.distance, rule.clearance) == (10.0, 1.5)

    def passing(me: KartView, other: KartView, lane: int, detector: PassDetector = rule) -> bool:
        return detector.exact_lanes(_scene(me, [other], _plan(me.checkpoints_passed + 1, {0: (lane,)})))

    s = float(OVAL.checkpoint_s[BACK_STRAIGHT]) + 2.0
    me = _on_oval(0, s, 1.25, BACK_STRAIGHT)
    ahead = _on_oval(1, s + 6.0, 1.25, BACK_STRAIGHT, speed=12.0)
    assert passing(me, ahead, 3)  # lane 3: 2.5 m clear of it
    assert not passing(me, ahead, 2)  # its own lane: following it
    assert not passing(me, _on_oval(1, s + 12.0, 1.25, BACK_STRAIGHT, speed=12.0), 3)  # too far ahead
    assert not passing(me, _on_oval(1, s - 6.0, 1.25, BACK_STRAIGHT, speed=12.0), 3)  # behind
    assert not passing(me, _on_oval(1, s + 6.0, 1.25, BACK_STRAIGHT, speed=15.0), 3)  # at the line's pace
    assert passing(me, _on_oval(1, s + 12.0, 1.25, BACK_STRAIGHT, speed=12.0), 3, replace(rule, distance=15.0))
    c = float(OVAL.checkpoint_s[CURVE]) + 2.0
    assert not passing(_on_oval(0, c, 1.25, CURVE), _on_oval(1, c + 6.0, 1.25, CURVE, speed=12.0), 3)


def test_a_pass_where_the_kart_ahead_is_predicted_to_leave_the_lane_is_driven_in_it() -> None:
    """The same when the kart ahead is in the ego's next planned lane now but the plan predicts it a lane (2.25-2.5
    m) away at one of the ego's next two waypoints: a line follower moving over ahead of a curve, which the ego,
    blending toward the line, used to follow into its wake. Not when the prediction keeps it in the ego's lanes,
    when only a later waypoint differs, or with ``on_prediction`` off."""
    rule = _preset(PassDetector)
    assert isinstance(rule, PassDetector) and rule.on_prediction
    s = float(OVAL.checkpoint_s[BACK_STRAIGHT]) + 2.0
    me = _on_oval(0, s, 1.25, BACK_STRAIGHT)
    ahead = _on_oval(1, s + 6.0, 1.25, BACK_STRAIGHT, speed=12.0)  # in lane 2, the ego's lane

    def passing(theirs: tuple[int, ...], mine: tuple[int, ...] = (2, 2, 2), detector: PassDetector = rule) -> bool:
        return detector.exact_lanes(_scene(me, [ahead], _plan(BACK_STRAIGHT + 1, {0: mine, 1: theirs})))

    assert passing((2, 1, 1))  # it leaves for lane 1 at the ego's second waypoint
    assert passing((3, 3, 3))  # ... or lane 3 at the first
    assert not passing((2, 2, 2))  # it stays ahead in the ego's lane: following
    assert not passing((2, 2, 1))  # it leaves only beyond the ego's next two waypoints
    assert not passing((2, 1, 1), mine=(2, 1, 1))  # the ego follows it over
    assert not passing((2, 1, 1), detector=replace(rule, on_prediction=False))


def test_with_its_lane_changes_spent_on_a_straight_it_steers_for_no_other_lane() -> None:
    """The lane-rule guard: on a straight with k of the rule's L changes left, the kart is to stay within the lanes
    k changes reach from the lane it is in, 0.2 m inside their outer boundaries, until the straight ends. Far from
    its end the aim is held there; near it the aim may lie as far out as the kart cannot follow in the time left
    (pure pursuit closes on the aim with its lookahead's time constant). On a curve (no limit there) or with every
    lane in reach it is free. The aim itself is clamped."""
    rule = _preset(LaneRuleGuard)
    assert rule == LaneRuleGuard(margin=0.2)
    limit = OVAL.lane_change_limit
    assert all(OVAL.section_is_straight(c) for c in range(10, 16)) and not OVAL.section_is_straight(16)
    offsets = OVAL.lane_offsets(BACK_STRAIGHT + 1)
    boundary_1_2, boundary_2_3, boundary_3_4 = (0.5 * float(offsets[i] + offsets[i + 1]) for i in range(3))
    margin, lane_2 = 0.2, float(offsets[1])

    def bounds(lane: int, changes: int, passed: int = BACK_STRAIGHT, to_go: float | None = None):  # type: ignore[no-untyped-def]
        s = float(OVAL.checkpoint_s[passed]) + 3.0 if to_go is None else float(OVAL.checkpoint_s[16]) - to_go
        me = replace(_on_oval(0, s, lane_2, passed), lane_now=lane, lane_changes_now=changes)
        assert isinstance(rule, LaneRuleGuard)
        return rule.bounds(_scene(me, []))

    held = (pytest.approx(boundary_2_3 + margin, abs=0.01), pytest.approx(boundary_1_2 - margin, abs=0.01))
    assert bounds(2, limit) == held  # spent, 47 m from the curve: its own lane only
    assert bounds(2, limit + 1) == held
    one_left = bounds(2, limit - 1)  # one change left: lanes 1 to 3
    assert one_left is not None and one_left[0] == pytest.approx(boundary_3_4 + margin, abs=0.01)
    assert one_left[1] == math.inf
    assert bounds(2, limit - 2) is None  # every lane in reach
    assert bounds(2, limit, passed=CURVE) is None
    near = bounds(2, limit, passed=15, to_go=2.0)  # 2 m (0.14 s) before the curve: it cannot follow far by then
    assert near is not None and near[0] < boundary_3_4 and near[1] > boundary_1_2 + 1.0
    halfway = bounds(2, limit, passed=15, to_go=5.0)
    assert halfway is not None and near[0] < halfway[0] < boundary_2_3 + margin - 0.1
    tracker = LQNGTracker(MCTS_TRACKING, MCTS_TRAFFIC)
    tracker.reset(RaceContext(OVAL, PAPER_KART, 0, 2, limit, 0))
    me = _on_oval(0, float(OVAL.checkpoint_s[BACK_STRAIGHT]) + 3.0, lane_2, BACK_STRAIGHT)
    far_right = Waypoint(BACK_STRAIGHT + 1, 4, tuple(OVAL.lane_point(BACK_STRAIGHT + 1, 4)), 15.0, 0.0)  # type: ignore[arg-type]
    free = tracker.aim_offset(me, far_right, far_right, 0.0)
    aim = tracker.aim_offset(me, far_right, far_right, 0.0, (boundary_2_3 + margin, boundary_1_2 - margin))
    assert free < boundary_2_3 and aim == boundary_2_3 + margin


def test_alongside_it_steers_for_no_offset_nearer_the_other_kart_than_the_clearance() -> None:
    """The alongside discipline: with a kart closer than 2.5 m along the track, it steers for no lateral offset
    nearer to that kart than 1.5 m centre to centre, and where the two are already closer, for one 0.2 m further
    from it than it is now (the referee charges the kart that moves sideways into one alongside). A kart further
    along leaves it free; a kart on each side holds it where it is. The earlier rule's bounds win where two do not
    overlap (the preset lists the lane-rule guard first)."""
    rule = _preset(AlongsideDiscipline)
    assert rule == AlongsideDiscipline(clearance=1.5, reach=2.5, push=0.2)
    assert MCTS_TRAFFIC.index(LaneRuleGuard(margin=0.2)) < MCTS_TRAFFIC.index(rule)  # type: ignore[arg-type]
    s = float(OVAL.checkpoint_s[11]) + 2.0
    me = _on_oval(0, s, 1.0, 11)

    def bounds(*others: KartView) -> tuple[float, float] | None:
        assert isinstance(rule, AlongsideDiscipline)
        return rule.bounds(_scene(me, list(others)))

    assert bounds(_on_oval(1, s + 0.5, -1.0, 11)) == pytest.approx((0.5, math.inf))  # on the right, 2 m away
    assert bounds(_on_oval(1, s - 1.5, 0.0, 11)) == pytest.approx((1.2, math.inf))  # 1 m away: 0.2 m further out
    assert bounds(_on_oval(1, s + 1.0, 3.0, 11)) == pytest.approx((-math.inf, 1.5))  # on the left
    assert bounds(_on_oval(1, s + 3.0, 0.0, 11)) is None  # ahead, not alongside: station keeping's business
    both = bounds(_on_oval(1, s + 0.5, -0.2, 11), _on_oval(2, s - 0.5, 2.2, 11))
    assert both == pytest.approx((1.0, 1.0))  # hemmed in: hold the line between them
    assert within((0.0, 2.0), (0.5, math.inf)) == (0.5, 2.0)
    assert within((0.0, 2.0), (2.5, math.inf)) == (0.0, 2.0)  # the first rule's alone
    assert within(None, (0.5, math.inf)) == (0.5, math.inf) and within((0.0, 2.0), None) == (0.0, 2.0)


def test_the_steer_rate_limit_clips_a_jump_to_the_rate_and_passes_a_small_change() -> None:
    rule = SteerRateLimit(rate=5.0)
    assert rule.filter_steer(1.0, 0.0) == pytest.approx(5.0 * DT)
    assert rule.filter_steer(-1.0, 0.3) == pytest.approx(0.3 - 5.0 * DT)
    assert rule.filter_steer(0.05, 0.0) == 0.05


def test_the_tracker_sorts_each_rule_into_its_role_and_keeps_the_presets_order() -> None:
    tracker = mcts_tracker(horizon=4)
    assert tracker.rules == MCTS_TRAFFIC and tracker.params.horizon == 4
    assert [type(r).__name__ for r in tracker._exact] == ["LanesExactAlongside", "PassDetector"]
    assert [type(r).__name__ for r in tracker._bounds] == ["LaneRuleGuard", "AlongsideDiscipline"]
    assert [type(r).__name__ for r in tracker._limits] == ["StationKeeping", "Yield"]
    assert [type(r).__name__ for r in tracker._steer_filters] == ["SteerRateLimit"]


def _cut_in(rules: tuple[object, ...], ahead: float, across_deg: float, steer: float) -> list[int]:
    """Collisions at fault (ego, other) of 3 s on the oval's back straight: the ego (mcts-lqng's tracker with
    ``rules``) at 9 m/s in lane 2; a kart 2 m to its left and ``ahead`` m in front at 12 m/s, heading
    ``across_deg`` toward it and steering ``steer`` for 0.5 s, at full throttle: a faster kart cutting in."""
    world = World(OVAL, 1, 2, SimParams(kart=PAPER_KART))
    s0, d0 = float(OVAL.checkpoint_s[BACK_STRAIGHT]) + 5.0, float(OVAL.lane_offsets(BACK_STRAIGHT + 1)[1])
    world.clear_race(0)
    world.place_kart(0, 0, s0, d0, speed=9.0)
    world.place_kart(0, 1, s0 + ahead, d0 + 2.0, speed=12.0, heading_offset=-math.radians(across_deg))
    world.sense()
    tracker = LQNGTracker(MCTS_TRACKING, rules)  # type: ignore[arg-type]
    tracker.reset(RaceContext(OVAL, PAPER_KART, 0, 2, OVAL.lane_change_limit, 0))
    actions = np.zeros((1, 2, 2))
    for step in range(150):
        action = tracker.act(observe(world, 0)[0], None)
        actions[0, 0] = (action.steer, action.throttle)
        actions[0, 1] = (steer if step < 25 else 0.0, 1.0)
        world.step(actions)
    return [int(world.istate[0, k, st.I_FAULTS]) for k in range(2)]


@pytest.mark.parametrize(("ahead", "across_deg", "steer"), [(0.5, 10.0, -0.1), (0.5, 15.0, -0.1), (1.0, 15.0, -0.2)])
def test_a_kart_cutting_in_is_let_in_and_without_the_yield_the_follower_hits_it(
    ahead: float, across_deg: float, steer: float
) -> None:
    """Placed karts: a kart 3 m/s faster cuts across from alongside into the ego's lane. mcts-lqng's tracker brakes
    at once and lets it in, no collision; the same tracker without the yield runs into it, at fault as the kart
    behind."""
    without = tuple(rule for rule in MCTS_TRAFFIC if not isinstance(rule, Yield))
    assert _cut_in(MCTS_TRAFFIC, ahead, across_deg, steer) == [0, 0]
    assert _cut_in(without, ahead, across_deg, steer)[0] == 1


@pytest.mark.parametrize("ego_lane", [1, 2])
def test_under_the_rules_of_the_road_the_fixed_line_keeps_off_two_slower_karts_abreast(ego_lane: int) -> None:
    """The ego rolls at 10 m/s 8 m behind two karts side by side in lanes 1 and 2 of the oval's straight, both at
    pace 0.8. The paper's Fixed-LQNG (the fixed line, its LQ game and no traffic rules) runs into one of them, at
    fault; the registered ``fixed-lqng`` (the same under mcts-lqng's rules of the road) keeps station, then
    passes, untouched."""

    def faults(ego: Controller | None) -> int:
        placements = (Placement(5.0, ego_lane, 10.0), Placement(13.0, 1, 10.0), Placement(13.0, 2, 10.0))
        leaders = ("lane-follower@0.8", "lane-follower@0.8")
        spec = RaceSpec(track="oval", controllers=("fixed-lqng", *leaders), time_limit=15.0, placements=placements)
        drivers = None if ego is None else [ego, make_agent(leaders[0]), make_agent(leaders[1])]
        return run_race(spec, drivers=drivers).result.karts[0].collisions_at_fault

    params = FixedLQNGParams()
    papers = HierarchicalController(
        "paper-fixed-lqng",
        FixedLinePlanner(margin=params.line_margin_m),
        fixed_line_tracker(params.lqng_horizon_steps, traffic=()),
    )
    assert faults(papers) >= 1
    assert faults(None) == 0
