"""The LQNG tracker's steering rate limit: in a real duel the tactical driver's steer input never changes
faster than its preset's rate, while the same duel without the limit does (so the limit is what holds it); its
speed scale, a handicapped kart's top speed; and whom it keeps station behind."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from controllers.base import Action, RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import CLOSE_FOLLOWING_TRACKING, MCTS_TRACKING, LQNGParams, LQNGTracker, _within
from controllers.plan import Plan, Waypoint
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from sim_core.kart import kart_step, lateral_limit, yaw_for_wear
from sim_core.observation import KartView, Observation, observe
from sim_core.params import DT, PAPER_KART
from sim_core.track_io import get_track
from sim_core.world import World


class RecordingTracker:
    """An LQNG tracker that keeps every steer input it returns."""

    def __init__(self, inner: LQNGTracker) -> None:
        self.inner = inner
        self.steers: list[float] = []

    def reset(self, context: RaceContext) -> None:
        self.inner.reset(context)

    def act(self, observation: Observation, plan: Plan | None) -> Action:
        action = self.inner.act(observation, plan)
        self.steers.append(action.steer)
        return action


def _steer_rates(steer_rate: float) -> np.ndarray:
    """Steer input changes per second of mcts-lqng over the first 10 s of a complex duel (seed 0, lane 2)."""
    driver = make_controller("mcts-lqng")
    assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
    recorder = RecordingTracker(LQNGTracker(replace(driver.tracker.params, steer_rate=steer_rate)))
    driver.tracker = recorder
    spec = RaceSpec(
        track="complex", controllers=("mcts-lqng", "fixed-lqng"), seed=0, start_lanes=(2, 3), time_limit=10.0
    )
    run_race(spec, drivers=[driver, make_controller("fixed-lqng")])
    assert len(recorder.steers) >= 400
    return np.abs(np.diff(recorder.steers)) / DT


def test_the_tactical_tracker_rate_limits_its_steering_in_traffic() -> None:
    assert MCTS_TRACKING.steer_rate > 0.0
    limited = _steer_rates(MCTS_TRACKING.steer_rate)
    assert limited.max() <= MCTS_TRACKING.steer_rate + 1e-9
    unlimited = _steer_rates(0.0)
    assert unlimited.max() > MCTS_TRACKING.steer_rate


def _top_speed(speed_scale: float) -> float:
    """The highest speed [m/s] fixed-lqng reaches in a lap of the oval alone at ``speed_scale``."""
    fastest = [0.0]

    def record(world: World, drivers: object, step: int) -> None:
        fastest[0] = max(fastest[0], observe(world, 0)[0].me.speed)

    spec = RaceSpec(track="oval", controllers=("fixed-lqng",), laps=1, seed=0)
    run_race(spec, on_step=record, drivers=[make_controller("fixed-lqng", speed_scale=speed_scale)])
    return fastest[0]


def test_a_handicapped_kart_keeps_to_its_speed_scale() -> None:
    assert _top_speed(1.0) > 0.97 * PAPER_KART.top_speed
    assert _top_speed(0.8) <= 0.8 * PAPER_KART.top_speed + 0.1


def _kart(index: int, x: float, y: float, speed: float) -> KartView:
    """A kart on a straight along +x (lateral offset = y)."""
    return KartView(index, x, y, 0.0, speed, x, y, 0.25, 1, 2, 0, 0.0, speed, 0.25, False)


def test_station_keeping_holds_behind_a_kart_in_its_path_and_not_beside_it() -> None:
    """mcts-lqng's tracker keeps station (0.15 s + 3 m) behind a slower kart within 1.0 m of it sideways, or within
    1.2 m of where it steers; pulling out to pass, 1.3 m aside and steering 2.5 m away, it is free to go by."""
    tracker = LQNGTracker(MCTS_TRACKING)
    me = _kart(0, 0.0, 0.0, 15.0)
    gap = MCTS_TRACKING.follow_distance + MCTS_TRACKING.follow_time * me.speed
    slower = 13.0
    straight_ahead = _kart(1, gap, 0.5, slower)
    assert tracker._station_limit(me, [straight_ahead], aim_offset=2.5) == slower
    beside_the_path = _kart(1, gap, 1.3, slower)
    assert tracker._station_limit(me, [beside_the_path], aim_offset=-1.2) == math.inf  # pulling out the other way
    assert tracker._station_limit(me, [beside_the_path], aim_offset=1.0) == slower  # cutting in behind it
    closer = _kart(1, gap - 1.0, 0.5, slower)
    assert tracker._station_limit(me, [closer], aim_offset=0.0) == slower - MCTS_TRACKING.follow_gain * 1.0
    alongside = _kart(1, MCTS_TRACKING.follow_min_ahead, 0.2, slower)
    assert tracker._station_limit(me, [alongside], aim_offset=0.0) == math.inf  # the alongside rule, not braking


def test_the_safe_speed_is_gipps_hand_checked_and_stops_short_of_a_kart_braking_ahead() -> None:
    """``close_following``'s station keeping: Gipps' safe speed with b = 6 m/s^2, tau = 0.05 s, a 2.3 m standoff
    on straights and 3.0 m in curves. Behind a standing kart 5.3 m (6.0 m in a curve) ahead, v = sqrt(0.3^2 + 2 *
    6 * 3) - 0.3 = 5.7075 m/s. The oracle: a kart at the safe speed that brakes at b after tau stops, with the kart
    ahead braking at b from its speed, no closer than the standoff."""
    close = CLOSE_FOLLOWING_TRACKING
    assert (close.follow_safe_braking, close.follow_time, close.follow_distance, close.follow_distance_curve) == (
        6.0,
        0.05,
        2.3,
        3.0,
    )
    tracker = LQNGTracker(close)
    me = _kart(0, 0.0, 0.0, 9.0)
    expected = math.sqrt(0.3**2 + 2 * 6.0 * 3.0) - 0.3
    assert tracker._station_limit(me, [_kart(1, 5.3, 0.0, 0.0)], 0.0, straight=True) == pytest.approx(expected)
    assert tracker._station_limit(me, [_kart(1, 6.0, 0.0, 0.0)], 0.0, straight=False) == pytest.approx(expected)
    assert tracker._station_limit(me, [_kart(1, 2.3, 0.0, 0.0)], 0.0, straight=True) == 0.0  # at the standoff
    b, tau, standoff = 6.0, 0.05, 2.3
    for ahead, other_speed in ((4.0, 14.0), (8.0, 10.0), (3.0, 5.0), (12.0, 2.0)):
        v = tracker._station_limit(me, [_kart(1, ahead, 0.0, other_speed)], 0.0, straight=True)
        follower_stop = v * tau + v * v / (2 * b)
        leader_stop = ahead + other_speed**2 / (2 * b)
        assert leader_stop - follower_stop == pytest.approx(standoff)
        # the gap along the way never falls below the standoff (both braking at b, the follower after tau)
        t = np.linspace(0.0, tau + v / b, 400)
        follower = np.where(t < tau, v * t, v * tau + v * (t - tau) - 0.5 * b * (t - tau) ** 2)
        leader_t = np.minimum(t, other_speed / b)
        leader = ahead + other_speed * leader_t - 0.5 * b * leader_t**2
        assert (leader - follower).min() >= standoff - 1e-9


def _on_oval(index: int, progress: float, lateral: float, passed: int, speed: float = 14.0) -> KartView:
    """A kart on the oval at ``progress`` [m] along the centre line and ``lateral`` [m] from it."""
    track = get_track("oval")
    point, tangent = track.point_at(progress)
    x, y = float(point[0] - tangent[1] * lateral), float(point[1] + tangent[0] * lateral)
    heading = math.atan2(float(tangent[1]), float(tangent[0]))
    return KartView(index, x, y, heading, speed, progress, lateral, 0.25, passed, 2, 0, 0.0, speed, 0.25, False)


def test_it_yields_to_a_faster_kart_cutting_across_from_alongside() -> None:
    """mcts-lqng's tracker brakes at once (a limit 0.6 m/s under its own speed) for a kart 2 m/s or more faster,
    alongside or less than the 2.3 m standoff ahead, that will be within 1.0 m sideways within 0.4 s: 2.0 m to its
    left and 0.5 m ahead at 12 m/s, heading 15 degrees across toward it (3.1 m/s sideways, 1.24 m in 0.4 s). Not
    when that kart holds its line, is not faster by the margin, is further back than the alongside reach, or with
    the rule off. (On complex, fixed-rl passed this way at 11-12 m/s against 8 and cut in 2.2 m ahead: a collision
    at fault by the follower in half of mcts-lqng's lane-3 starts.)"""
    track = get_track("oval")
    params = CLOSE_FOLLOWING_TRACKING
    assert (params.yield_speed_margin, params.yield_drop, params.follow_predict_time) == (2.0, 0.6, 0.4)
    straight = 11  # the oval's back straight runs from checkpoint 10 to 16
    s = float(track.checkpoint_s[straight]) + 5.0
    me = _on_oval(0, s, 0.0, straight, speed=9.0)
    across = math.radians(15.0)

    def limit(other: KartView, tracker_params: LQNGParams = params) -> float:
        tracker = LQNGTracker(tracker_params)
        return tracker._station_limit(me, [other], aim_offset=0.0, straight=True, track=track)

    cutting_in = _on_oval(1, s + 0.5, 2.0, straight, speed=12.0)
    cutting_in = replace(cutting_in, heading=cutting_in.heading - across)
    assert limit(cutting_in) == pytest.approx(9.0 - 0.6)
    holding_its_line = _on_oval(1, s + 0.5, 2.0, straight, speed=12.0)
    assert limit(holding_its_line) == math.inf
    not_faster_enough = replace(cutting_in, speed=10.5)
    assert limit(not_faster_enough) == math.inf
    behind = _on_oval(1, s - 3.0, 2.0, straight, speed=12.0)
    assert limit(replace(behind, heading=behind.heading - across)) == math.inf
    assert limit(cutting_in, replace(params, yield_speed_margin=0.0)) == math.inf


def test_a_pass_planned_on_a_straight_is_driven_in_its_lane() -> None:
    """mcts-lqng's tracker drives its planned lanes exactly (no blending toward the line) while passing: on a
    straight, behind a kart within ``pass_distance`` that drives under the racing line's speed there, with the next
    planned lane 1.5 m or more clear of it sideways. Not when the planned lane is in the other kart's wake, the kart
    is further ahead, behind, or at the line's pace (behind such a kart, driven exactly, it crossed lanes early into
    the next curve: an illegal lane change in 38 of the paper grid's 400 races), or on a curve."""
    track = get_track("oval")
    assert 0.0 < MCTS_TRACKING.pass_distance < 15.0

    def passing(me: KartView, other: KartView, lane: int, checkpoint: int, params: LQNGParams = MCTS_TRACKING) -> bool:
        point = track.lane_point(checkpoint, lane)
        waypoint = Waypoint(checkpoint, lane, (float(point[0]), float(point[1])), 15.0, 0.0)
        plan = Plan(0, checkpoint - 1, {0: (waypoint,)}, 1, 1, 0.0)
        tracker = LQNGTracker(params)
        tracker.reset(RaceContext(track, PAPER_KART, 0, 2, track.lane_change_limit, 0))
        return tracker._passing(track, me, [other], plan)

    straight = 11  # the oval's back straight runs from checkpoint 10 to 16
    assert track.section_is_straight(straight) and not track.section_is_straight(8)
    s = float(track.checkpoint_s[straight]) + 2.0
    me = _on_oval(0, s, 1.25, straight)
    ahead = _on_oval(1, s + 6.0, 1.25, straight, speed=12.0)
    assert passing(me, ahead, 3, straight + 1)  # lane 3: 2.5 m clear of it
    assert not passing(me, ahead, 2, straight + 1)  # its own lane: following it
    assert not passing(me, _on_oval(1, s + 12.0, 1.25, straight, speed=12.0), 3, straight + 1)  # too far ahead
    assert not passing(me, _on_oval(1, s - 6.0, 1.25, straight, speed=12.0), 3, straight + 1)  # behind
    assert not passing(me, _on_oval(1, s + 6.0, 1.25, straight, speed=15.0), 3, straight + 1)  # at the line's pace
    assert not passing(me, ahead, 3, straight + 1, replace(MCTS_TRACKING, pass_distance=0.0))
    curve = 8
    c = float(track.checkpoint_s[curve]) + 2.0
    assert not passing(_on_oval(0, c, 1.25, curve), _on_oval(1, c + 6.0, 1.25, curve, speed=12.0), 3, curve + 1)
    assert MCTS_TRACKING.pass_clearance == 1.5


def test_a_pass_where_the_kart_ahead_is_predicted_to_leave_the_lane_is_driven_in_it() -> None:
    """mcts-lqng's tracker also drives its lanes exactly when the kart ahead is in the ego's next planned lane now
    but the plan predicts it a lane (2.25-2.5 m) away at one of the ego's next two waypoints: a line follower moving
    over ahead of a curve, which the ego, blending toward the line, used to follow into its wake. Not when the
    prediction keeps it in the ego's lanes, when only a later waypoint differs, or with ``pass_on_prediction`` off."""
    track = get_track("oval")
    assert MCTS_TRACKING.pass_on_prediction and not LQNGParams().pass_on_prediction

    def waypoints(checkpoint: int, lanes: tuple[int, ...]) -> tuple[Waypoint, ...]:
        out = []
        for k, lane in enumerate(lanes):
            point = track.lane_point(checkpoint + k, lane)
            out.append(Waypoint(checkpoint + k, lane, (float(point[0]), float(point[1])), 15.0, 0.0))
        return tuple(out)

    straight = 11  # the oval's back straight runs from checkpoint 10 to 16
    s = float(track.checkpoint_s[straight]) + 2.0
    me = _on_oval(0, s, 1.25, straight)
    ahead = _on_oval(1, s + 6.0, 1.25, straight, speed=12.0)  # in lane 2, the ego's lane

    def passing(theirs: tuple[int, ...], mine: tuple[int, ...] = (2, 2, 2), params: LQNGParams = MCTS_TRACKING) -> bool:
        plan = Plan(0, straight, {0: waypoints(straight + 1, mine), 1: waypoints(straight + 1, theirs)}, 1, 1, 0.0)
        tracker = LQNGTracker(params)
        tracker.reset(RaceContext(track, PAPER_KART, 0, 2, track.lane_change_limit, 0))
        return tracker._passing(track, me, [ahead], plan)

    assert passing((2, 1, 1))  # it leaves for lane 1 at the ego's second waypoint
    assert passing((3, 3, 3))  # ... or lane 3 at the first
    assert not passing((2, 2, 2))  # it stays ahead in the ego's lane: following
    assert not passing((2, 2, 1))  # it leaves only beyond the ego's next two waypoints
    assert not passing((2, 1, 1), mine=(2, 1, 1))  # the ego follows it over
    assert not passing((2, 1, 1), params=replace(MCTS_TRACKING, pass_on_prediction=False))


def test_with_its_lane_changes_spent_on_a_straight_it_steers_for_no_other_lane() -> None:
    """mcts-lqng's lane-rule guard: on a straight with k of the rule's L changes left, the kart is to stay within the
    lanes k changes reach from the lane it is in, 0.2 m inside their outer boundaries, until the straight ends. Far
    from its end the aim is held there; near it the aim may lie as far out as the kart cannot follow in the time
    left (pure pursuit closes on the aim with its lookahead's time constant). On a curve (no limit there), with
    every lane in reach, or with the guard off, it is free. The aim itself is clamped."""
    track = get_track("oval")
    limit = track.lane_change_limit
    straight = 11  # the oval's back straight runs from checkpoint 10 to 16
    assert track.section_is_straight(straight) and not track.section_is_straight(16)
    assert all(track.section_is_straight(c) for c in range(10, 16)) and not track.section_is_straight(8)
    offsets = track.lane_offsets(straight + 1)
    boundary_1_2, boundary_2_3, boundary_3_4 = (0.5 * float(offsets[i] + offsets[i + 1]) for i in range(3))
    margin = MCTS_TRACKING.lane_guard_margin
    lane_2 = float(offsets[1])

    def bounds(  # type: ignore[no-untyped-def]
        lane: int, changes: int, passed: int = straight, params: LQNGParams = MCTS_TRACKING, to_go: float | None = None
    ):
        s = float(track.checkpoint_s[passed]) + 3.0 if to_go is None else float(track.checkpoint_s[16]) - to_go
        me = replace(_on_oval(0, s, lane_2, passed), lane_now=lane, lane_changes_now=changes)
        tracker = LQNGTracker(params)
        tracker.reset(RaceContext(track, PAPER_KART, 0, 2, limit, 0))
        return tracker._lane_rule_bounds(track, me)

    held = (pytest.approx(boundary_2_3 + margin, abs=0.01), pytest.approx(boundary_1_2 - margin, abs=0.01))
    assert bounds(2, limit) == held  # spent, 47 m from the curve: its own lane only
    assert bounds(2, limit + 1) == held
    one_left = bounds(2, limit - 1)  # one change left: lanes 1 to 3
    assert one_left is not None and one_left[0] == pytest.approx(boundary_3_4 + margin, abs=0.01)
    assert one_left[1] == math.inf
    assert bounds(2, limit - 2) is None  # every lane in reach
    assert bounds(2, limit, passed=8) is None  # a curve
    assert bounds(2, limit, params=replace(MCTS_TRACKING, lane_rule_guard=False)) is None
    near = bounds(2, limit, passed=15, to_go=2.0)  # 2 m (0.14 s) before the curve: it cannot follow far by then
    assert near is not None and near[0] < boundary_3_4 and near[1] > boundary_1_2 + 1.0
    halfway = bounds(2, limit, passed=15, to_go=5.0)
    assert halfway is not None and near[0] < halfway[0] < boundary_2_3 + margin - 0.1
    tracker = LQNGTracker(MCTS_TRACKING)
    tracker.reset(RaceContext(track, PAPER_KART, 0, 2, limit, 0))
    me = _on_oval(0, float(track.checkpoint_s[straight]) + 3.0, lane_2, straight)
    far_right = Waypoint(straight + 1, 4, tuple(track.lane_point(straight + 1, 4)), 15.0, 0.0)  # type: ignore[arg-type]
    _, _, free = tracker._aim(track, me, far_right, far_right, 0.0)
    _, _, aim = tracker._aim(track, me, far_right, far_right, 0.0, (boundary_2_3 + margin, boundary_1_2 - margin))
    assert free < boundary_2_3 and aim == boundary_2_3 + margin


def test_alongside_it_steers_for_no_offset_nearer_the_other_kart_than_the_clearance() -> None:
    """mcts-lqng's alongside discipline: with a kart closer than 2.5 m along the track, it steers for no lateral
    offset nearer to that kart than 1.5 m centre to centre, and where the two are already closer, for one 0.2 m
    further from it than it is now (the referee charges the kart that moves sideways into one alongside). Hand
    checked on the oval's back straight; a kart further along, or the discipline off, leaves it free; a kart on
    each side holds it where it is. The lane rule's bounds win where the two do not overlap."""
    track = get_track("oval")
    assert (MCTS_TRACKING.alongside_clearance, MCTS_TRACKING.alongside_reach) == (1.5, 2.5)
    assert MCTS_TRACKING.alongside_push == 0.2
    assert CLOSE_FOLLOWING_TRACKING.alongside_clearance == 1.5
    s = float(track.checkpoint_s[11]) + 2.0
    me = _on_oval(0, s, 1.0, 11)

    def bounds(*others: KartView, params: LQNGParams = MCTS_TRACKING) -> tuple[float, float] | None:
        return LQNGTracker(params)._alongside_bounds(track, me, list(others))

    assert bounds(_on_oval(1, s + 0.5, -1.0, 11)) == pytest.approx((0.5, math.inf))  # on the right, 2 m away
    assert bounds(_on_oval(1, s - 1.5, 0.0, 11)) == pytest.approx((1.2, math.inf))  # 1 m away: 0.2 m further out
    assert bounds(_on_oval(1, s + 1.0, 3.0, 11)) == pytest.approx((-math.inf, 1.5))  # on the left
    assert bounds(_on_oval(1, s + 3.0, 0.0, 11)) is None  # ahead, not alongside: station keeping's business
    assert bounds(_on_oval(1, s + 0.5, 0.0, 11), params=replace(MCTS_TRACKING, alongside_clearance=0.0)) is None
    both = bounds(_on_oval(1, s + 0.5, -0.2, 11), _on_oval(2, s - 0.5, 2.2, 11))
    assert both == pytest.approx((1.0, 1.0))  # hemmed in: hold the line between them
    assert _within((0.0, 2.0), (0.5, math.inf)) == (0.5, 2.0)
    assert _within((0.0, 2.0), (2.5, math.inf)) == (0.0, 2.0)  # the lane rule's alone
    assert _within(None, (0.5, math.inf)) == (0.5, math.inf) and _within((0.0, 2.0), None) == (0.0, 2.0)


def test_grip_steer_asks_for_no_more_curvature_than_the_tyres_hold() -> None:
    """``grip_steer``: the steer limit is the kart model's own (the bicycle's curvature 2 sin(beta) / wheelbase with
    tan(beta) = tan(delta) / 2) at the given fraction of the lateral limit: at 12 m/s and wear 0.25, driven through
    :func:`sim_core.kart.kart_step`, the limit at 1.0 steers without losing speed to traction control, and 5% more
    steer brakes at the full braking limit. Hand check of 0.98: the path curvature is 0.98 a_lat / v^2."""
    track = get_track("oval")
    me = _on_oval(0, float(track.checkpoint_s[11]) + 2.0, 0.0, 11, speed=12.0)

    def limit(fraction: float) -> float:
        tracker = LQNGTracker(replace(CLOSE_FOLLOWING_TRACKING, grip_steer=fraction))
        tracker.reset(RaceContext(track, PAPER_KART, 0, 2, track.lane_change_limit, 0))
        return tracker._grip_steer(me)

    p = PAPER_KART.as_array()
    a_lat = lateral_limit(p, me.wear)
    tan_beta = 0.5 * math.tan(limit(0.98) * PAPER_KART.max_steer_angle)
    curvature = 2.0 * tan_beta / math.sqrt(1.0 + tan_beta**2) / PAPER_KART.wheelbase
    assert curvature == pytest.approx(0.98 * a_lat / 12.0**2, rel=1e-9)
    yaw = yaw_for_wear(p, me.wear)

    def speed_after(steer: float) -> float:
        return kart_step(p, 0.0, 0.0, 0.0, 12.0, 0.0, yaw, steer, 0.0, DT)[3]

    assert speed_after(0.999 * limit(1.0)) == pytest.approx(speed_after(0.0), abs=1e-12)  # coasting only
    assert speed_after(1.05 * limit(1.0)) < speed_after(0.0) - 0.5 * PAPER_KART.braking * DT  # traction control


def test_grip_steer_is_lifted_with_a_kart_close_alongside_and_limits_the_steer_otherwise() -> None:
    """With ``grip_steer`` the tracker's steer stays within the limit when it is sent two lanes across at once
    (on the oval's back straight at 14 m/s, the plan's next waypoint in lane 4 from lane 2), and the limit is
    lifted while a kart is alongside (within ``alongside_distance`` along the track) and less than
    ``grip_steer_clearance`` sideways: steering and braking together keep the two apart there (a kart squeezed on
    the inside of complex's first corner ran into the one beside it, a collision at fault, when held to the
    limit). Without the option the same tracker asks for more."""
    track = get_track("oval")
    straight = 11
    s = float(track.checkpoint_s[straight]) + 1.0
    me = _on_oval(0, s, 1.25, straight)
    point = track.lane_point(straight + 1, 4)
    waypoint = Waypoint(straight + 1, 4, (float(point[0]), float(point[1])), 15.0, 0.0)
    plan = Plan(0, straight, {0: (waypoint,)}, 1, 1, 0.0)

    def steer(fraction: float, *others: KartView) -> tuple[float, float]:
        tracker = LQNGTracker(replace(CLOSE_FOLLOWING_TRACKING, grip_steer=fraction, steer_rate=0.0))
        tracker.reset(RaceContext(track, PAPER_KART, 0, 2, track.lane_change_limit, 0))
        observation = Observation(0.0, 0, (me, *others), np.full(9, 20.0), np.zeros(9, dtype=np.int64))
        return abs(tracker.act(observation, plan).steer), tracker._grip_steer(me)

    free, limit = steer(0.98)
    unlimited, _ = steer(0.0)
    assert unlimited > limit and free == pytest.approx(limit)
    beside = _on_oval(1, s + 0.5, 2.75, straight)  # 1.5 m to its left
    assert steer(0.98, beside)[0] > limit
    wide = _on_oval(1, s + 0.5, 3.75, straight)  # 2.5 m to its left: the limit holds
    assert steer(0.98, wide)[0] == pytest.approx(limit)
    tracker = LQNGTracker(replace(CLOSE_FOLLOWING_TRACKING, grip_steer=0.98))
    assert tracker._beside(track, me, [beside]) and not tracker._beside(track, me, [wide])
    assert not tracker._beside(track, me, [_on_oval(1, s + 6.0, 2.75, straight)])  # ahead, not alongside
