"""The LQNG tracker (paper section 4.2.3, eqs. (20)-(24)): a linear-quadratic Nash game over a few 0.02 s
steps, re-solved at every simulation step, that tracks the next waypoint while denying the opponents theirs
and keeping apart.

This module picks each player's targets (aim point, speed) and the weights; :mod:`controllers.lq.game` turns
them into the game (dynamics linearised at the current state, eq. (24) lqng_dyn) and
:mod:`controllers.lq.nash` solves it. Costs of player i (1/2 x'Qx + q'x), assembled as eq. (23) lqng_obj:

* eq. (20) lqng_obj1, own waypoint: w_pos |p_i - psi_i|^2 + w_v (v_i - psi_v)^2 + w_theta (dtheta_i - psi_theta)^2;
* eq. (21) lqng_obj2, denial: - w_deny |p_j - psi_j|^2 for each opponent j with a predicted waypoint within reach;
* eq. (22) lqng_obj3, separation: - w_avoid |p_i - p_j|^2 for each kart within ``avoid_radius``;
* controls: 1/2 r |u_i|^2 (not in eq. (23)).

The heading target points at a pure-pursuit aim point on the path that blends the kart's lateral offset
into the next waypoints' lanes along the track (a heading straight at a lane point would cut the inside of
bends). The tracker's acceleration and yaw rate are mapped to throttle and steer.

The two registered hierarchical drivers track with the named presets :data:`CLOSE_FOLLOWING_TRACKING` (mcts-lqng;
:data:`MCTS_TRACKING` with ``close_following=false``) and :data:`FIXED_LINE_TRACKING`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from controllers.base import Action, RaceContext
from controllers.lq.game import STATE_SIZE, solve_tracker_game
from controllers.plan import Plan, Waypoint
from controllers.racing_line import RacingLine, optimise_racing_line
from sim_core.kart import lateral_limit, throttle_for_acceleration
from sim_core.observation import KartView, Observation
from sim_core.params import DT
from sim_core.track import Track


def _lane_correction(lane_offset: float, line_offset: float, tolerance: float) -> float:
    gap = lane_offset - line_offset
    return 0.0 if abs(gap) <= tolerance else gap - math.copysign(tolerance, gap)


def _rate_across(track: Track, kart: KartView) -> float:
    """The kart's velocity across the track [m/s], left-positive, from its heading against the centre line's."""
    _, tangent = track.point_at(kart.progress)
    return kart.speed * (math.sin(kart.heading) * float(tangent[0]) - math.cos(kart.heading) * float(tangent[1]))


def _within(rule: tuple[float, float] | None, discipline: tuple[float, float] | None) -> tuple[float, float] | None:
    """The lateral bounds both the lane rule's ``rule`` and the alongside ``discipline`` allow; the rule's alone
    where the two do not overlap (holding a lane boundary beats closing a little on a kart alongside)."""
    if rule is None or discipline is None:
        return rule or discipline
    lowest, highest = max(rule[0], discipline[0]), min(rule[1], discipline[1])
    return (lowest, highest) if lowest <= highest else rule


@dataclass(frozen=True)
class LQNGWeights:
    """Weights of the tracker's game (defaults follow the original's magnitudes, spec section 5)."""

    position: float = 0.93  # w_pos = position / max(1, v)
    speed: float = 1.0  # w_v: pulls the speed to the planned speed
    heading: float = 3.5  # w_theta (the original: 3.5 with MCTS, 1.9 with the fixed line)
    # w_deny = deny / max(1, v) on the opponent's predicted waypoint; the original's 0.2 made the kart push the other
    deny: float = 0.02
    avoid_scale: float = 1.0  # w_avoid = 1 / (d^1.5 * avoid_scale) (the original: 1.0 MCTS, 0.45 fixed)
    opponent_avoid_scale: float = 1.3  # the same for the opponents' assumed costs
    control: float = 0.115  # r
    avoid_radius: float = 8.0  # [m] players closer than this enter the game


@dataclass(frozen=True)
class LQNGParams:
    """Tracker settings."""

    horizon: int = 4  # steps of 0.02 s (the paper: 0.06-0.08 s)
    lookahead_time: float = 0.45  # [s] pure-pursuit lookahead = max(min_lookahead, v * this)
    min_lookahead: float = 3.0  # [m]
    speed_margin: float = 1.0  # [m/s] added to planned speeds (the original added 2 bin widths)
    braking_use: float = 0.8  # fraction of the braking limit the speed target assumes
    lane_tolerance: float = 1.25  # [m] a waypoint lane within this of the racing line needs no correction
    # [m] the same with another kart within avoid_radius: planned lanes are then driven as planned, or two karts
    # planned into neighbouring lanes would both close onto the line and touch
    traffic_lane_tolerance: float = 0.0
    # [m] with another kart closer than this along the track (alongside), planned lanes are driven exactly
    # (tolerance 0) whatever ``traffic_lane_tolerance`` says: two karts blending onto one line would touch
    alongside_distance: float = 0.0
    # [m] on a straight, behind a kart closer than this along the track that is slower than the racing line there
    # (by ``pass_speed_margin``), with the next waypoint's lane at least ``pass_clearance`` sideways from it, planned
    # lanes are driven exactly too: the plan is a pass, and blending toward the line would leave the kart in the
    # other's wake, held back by station keeping; 0: off
    pass_distance: float = 0.0
    pass_clearance: float = 1.5  # [m]
    # a pass is also planned where the plan predicts the kart ahead in a lane ``pass_clearance`` sideways from the
    # ego's at one of its next two waypoints (it is about to leave the ego's lane, as a line follower does ahead
    # of a curve): blended toward the line, the ego followed it out of its lane and stayed in its wake
    pass_on_prediction: bool = False
    pass_speed_margin: float = 0.3  # [m/s]
    # [1/s] the steering input changes at most this fast (lock to lock in 2/rate s); 0: unlimited. A full-lock
    # zig-zag between planned lanes is what traction control turns into braking
    steer_rate: float = 0.0
    # > 0: the steer asks for at most this fraction of the curvature the tyres hold at the kart's speed and wear;
    # 0: off. Past it traction control brakes at the full braking limit (a 2.5 m lane change in a 9 m section
    # after a hairpin took a following kart from 10 to 5.9 m/s), where a driver eases the change and keeps speed.
    # Not with a kart alongside (within ``alongside_distance``): there steering and braking together keep clear
    grip_steer: float = 0.0
    grip_steer_clearance: float = 2.0  # [m] sideways: a kart alongside closer than this lifts the limit
    # keeping station behind a kart ahead (centres within ``follow_band`` laterally): at most its speed plus
    # ``follow_gain`` times the gap beyond ``follow_distance`` + ``follow_time`` * speed (or Gipps' safe speed,
    # ``follow_safe_braking`` below); 0 gain: off
    follow_gain: float = 0.0  # [1/s]
    follow_distance: float = 3.0  # [m] centre to centre (a kart length and a margin)
    follow_time: float = 0.25  # [s]
    follow_band: float = 1.6  # [m]
    # [m] also keep station behind a kart this close sideways to the lateral offset the kart steers for; 0: off
    follow_path_band: float = 0.0
    follow_brake_gain: float = 3.0  # [1/s] deceleration per m/s above the station-keeping speed
    # [m/s^2] > 0: keep station by the safe-speed rule of Gipps' car-following model instead (fast enough to stop
    # ``follow_distance`` short of where the kart ahead would stop, both braking at this rate, this kart after
    # ``follow_time`` at its speed): it closes up on a slower kart where braking leaves room and holds back where
    # it does not; 0: the linear rule above
    follow_safe_braking: float = 0.0
    follow_distance_curve: float = 0.0  # [m] > 0: ``follow_distance`` in curves (straights keep the other)
    # [m] a kart less than this ahead is alongside, not ahead (the referee's alongside rule): lane discipline,
    # not braking, keeps the two apart
    follow_min_ahead: float = 1.0
    # [s] > 0: a kart ahead (by more than ``follow_min_ahead``) also counts as in the path when, both carried on at
    # their present rates across the track, it would be within ``follow_band`` sideways within this time: a kart
    # drifting over in front is braked for before it is there (following 1.7 m behind a kart 1.5 m aside, close
    # following was hit by it as it drifted across, a collision at fault by the follower); 0: off
    follow_predict_time: float = 0.0
    # [m/s] > 0: let a passing kart in. One at least this much faster, alongside (within ``alongside_reach``) or
    # less than ``follow_distance`` ahead, that the two karts' rates across the track bring within ``follow_band``
    # sideways within ``follow_predict_time``, is braked for at once: the speed limit is ``yield_drop`` under the
    # kart's own, so it brakes at ``follow_brake_gain`` x ``yield_drop`` (6 m/s^2, full braking, when following
    # closely). Such a kart cuts in a body length ahead, and the contact is the follower's fault; station keeping
    # starts only once it is ahead, too late; 0: off
    yield_speed_margin: float = 0.0
    yield_drop: float = 0.6  # [m/s]
    # [m] > 0: alongside discipline. With another kart alongside (centres closer than ``alongside_reach`` along the
    # track), steer for no offset nearer to it sideways than this (centre to centre), and where the two are
    # already closer, for one no nearer than the present offset plus ``alongside_push``: the kart that moves
    # sideways into another alongside is at fault (the referee's alongside rule), and a line that runs out of a
    # corner across the other kart's did exactly that; 0: off
    alongside_clearance: float = 0.0
    alongside_reach: float = 2.5  # [m] a body length (2 m) and a margin
    alongside_push: float = 0.2  # [m]
    # on a straight with its lane changes spent (eq. (11) gen_lane_lim, counted as they happen), steer for no point
    # beyond the lanes the changes left reach, ``lane_guard_margin`` [m] short of the boundary: blending toward
    # the line and the next curve's lane otherwise crosses a boundary before the curve begins
    lane_rule_guard: bool = False
    lane_guard_margin: float = 0.2
    # fraction of its speed targets the kart drives at (its top speed included): 1 is all out, under 1 a
    # handicapped, uniformly slower kart (an opponent to test passing against)
    speed_scale: float = 1.0
    weights: LQNGWeights = LQNGWeights()


# ``mcts-lqng``: the game's speed bins are coarse, so planned speeds are a ceiling 3 m/s above the bin and the
# racing line's speed profile binds. Steering at most 5/s (lock to lock in 0.4 s) only clips the rare jumps of
# the solved input (up to 50/s where a new plan or a kart entering the game moves the aim point); the races it
# was sampled on had the same winners within 0.03 s (results/issue11/session9/README.md). Station keeping 0.15 s
# (not 0.25 s) behind a kart whose centre is within 1.0 m (not 1.6 m) of its own sideways, or within 1.2 m of
# where it steers: the old spacing held it so far back, and so long after it had started to pull out, that it
# followed a kart 15% slower home on complex; now it passes one 10% slower (8% slower in half the starts), and
# every race against an equal kart ends as before (results/issue11/session17/README.md). A pass planned on a straight
# (the next lane clear of the kart ahead by 1.5 m, within 10 m of it) is driven exactly: blended toward the line it
# stayed in the other's wake, held back by station keeping (results/issue11/session18/README.md); so is one where the
# kart ahead is predicted to leave the ego's lane (results/issue11/session20/README.md). With its lane changes
# of a straight spent, it keeps within reach of its lanes until the curve: races from a spread start crossed into
# the next curve's lane a few metres early, an illegal lane change (results/issue11/session19/README.md). With a
# kart alongside (within 2.5 m along the track) it steers for no offset nearer to it than 1.5 m, and a kart ahead
# that will drift into its path within 0.4 s is kept station behind already (results/issue11/session22/README.md).
# A kart 2 m/s or more faster, alongside or less than the standoff ahead, that will be in its path within 0.4 s is
# let in: it brakes at once (results/issue11/session23/README.md)
MCTS_TRACKING = LQNGParams(
    speed_margin=3.0,
    traffic_lane_tolerance=1.25,
    alongside_distance=4.0,
    pass_distance=10.0,
    pass_on_prediction=True,
    follow_gain=1.0,
    follow_time=0.15,
    follow_band=1.0,
    follow_path_band=1.2,
    steer_rate=5.0,
    lane_rule_guard=True,
    alongside_clearance=1.5,
    follow_predict_time=0.4,
    yield_speed_margin=2.0,
)
# ``mcts-lqng`` as registered (``close_following``, the default since session 22): station keeping by Gipps' safe
# speed (both braking at 6 m/s^2, this kart after 0.05 s; a standoff of 2.3 m centre to centre on straights, 3.0 m
# in curves). It follows 3.0 m behind at 14 m/s on a straight, where the linear rule holds 5.1 m, and dives inside
# at the straight's end: it passed a kart 7% slower in 16 of 16 starts on complex (the linear rule 10) and 5%
# slower in 5 (3) (results/issue11/session21/README.md). Session 21 kept it off by default: in the paper's grid its
# collisions at fault rose from 0.15 to 0.25 per race, side by side in curves and behind karts drifting across.
# The alongside discipline and the drift prediction of :data:`MCTS_TRACKING` took those away
# (results/issue11/session22/README.md)
CLOSE_FOLLOWING_HELP = (
    "keep station by Gipps' safe speed, 2.3 m behind on straights and 3.0 m in curves (ours; false: the linear "
    "spacing of 3 m + 0.15 s x speed, which passes slower karts less often)"
)
# off by default: in session 24's measurements (results/issue11/session24/README.md) it passed karts 3-5% slower
# far more often, but lost the paper grid's complex races against e2e (42 of 50 won without it, 2 with it)
GRIP_STEER_HELP = (
    "fraction of the tyres' grip the tracker's steering may ask for with no kart close alongside (0: off, "
    "traction control brakes whenever it asks for more); 0.98 passes slower karts far more often"
)
CLOSE_FOLLOWING_TRACKING = replace(
    MCTS_TRACKING,
    follow_safe_braking=6.0,
    follow_time=0.05,
    follow_distance=2.3,
    follow_distance_curve=3.0,
    follow_brake_gain=10.0,
)
# ``fixed-lqng``: the original's heading weight and avoidance scale with the fixed line (1.9, 0.45), a stronger
# denial, and the line's own lanes followed to within ``lane_tolerance`` in traffic as well
FIXED_LINE_TRACKING = LQNGParams(
    traffic_lane_tolerance=1.25, weights=LQNGWeights(heading=1.9, deny=0.1, avoid_scale=0.45)
)


class LQNGTracker:
    """Linear-quadratic Nash game tracker; works with any plan (MCTS waypoints or the fixed racing line)."""

    def __init__(self, params: LQNGParams | None = None) -> None:
        self.params = params or LQNGParams()
        self._context: RaceContext | None = None
        self._line: RacingLine | None = None
        self._kart_vector = np.zeros(0)
        self._steer = 0.0

    def reset(self, context: RaceContext) -> None:
        """Remember the track and kart limits and get the track's racing line (the shape followed between
        waypoints that agree with it)."""
        self._context = context
        self._kart_vector = context.kart.as_array()
        self._steer = 0.0
        self._line = optimise_racing_line(context.track, context.kart)

    # ------------------------------------------------------------------ targets
    def _upcoming(self, track: Track, kart: KartView, plan: Plan | None, owner: int) -> tuple[Waypoint, Waypoint]:
        """The next two waypoints of ``owner`` still ahead of ``kart`` (its current lane when none is planned)."""
        ahead: list[Waypoint] = []
        if plan is not None:
            ahead = [w for w in plan.waypoints.get(owner, ()) if w.checkpoint > kart.checkpoints_passed]
        while len(ahead) < 2:
            checkpoint = kart.checkpoints_passed + 1 + len(ahead)
            lane = ahead[-1].lane if ahead else kart.lane
            point = track.lane_point(checkpoint, lane)
            ahead.append(Waypoint(checkpoint, lane, (float(point[0]), float(point[1])), 15.0, 0.0))
        return ahead[0], ahead[1]

    def _aim(
        self,
        track: Track,
        kart: KartView,
        first: Waypoint,
        second: Waypoint,
        tolerance: float,
        bounds: tuple[float, float] | None = None,
    ) -> tuple[float, float, float]:
        """Pure-pursuit aim point (x, y) on the path blending the kart's lateral offset into the waypoints' lanes,
        and its lateral offset from the centre line [m], held within ``bounds`` (lowest, highest offset) if given."""
        p = self.params
        lookahead = max(p.min_lookahead, abs(kart.speed) * p.lookahead_time)
        n = track.n_checkpoints
        s1 = (track.checkpoint_s[first.checkpoint % n] - kart.progress) % track.length
        s2 = s1 + (track.checkpoint_s[second.checkpoint % n] - track.checkpoint_s[first.checkpoint % n]) % track.length
        d1 = track.lane_offsets(first.checkpoint)[first.lane - 1]
        d2 = track.lane_offsets(second.checkpoint)[second.lane - 1]
        # follow the racing line's shape, shifted where a waypoint's lane is away from it: the correction is
        # the lane's offset from the line (0 when the line already passes within half a lane of it)
        assert self._line is not None
        line = self._line
        aim_s = kart.progress + lookahead
        c1 = _lane_correction(d1, float(line.offset_at(kart.progress + s1)), tolerance)
        c2 = _lane_correction(d2, float(line.offset_at(kart.progress + s2)), tolerance)
        c_now = kart.lateral - float(line.offset_at(kart.progress))
        if lookahead <= s1:
            correction = c_now + (c1 - c_now) * lookahead / max(s1, 1e-6)
        else:
            correction = c1 + (c2 - c1) * min((lookahead - s1) / max(s2 - s1, 1e-6), 1.0)
        d = float(line.offset_at(aim_s)) + correction
        if bounds is not None:
            d = min(max(d, bounds[0]), bounds[1])
        point, tangent = track.point_at(aim_s)
        return float(point[0] - tangent[1] * d), float(point[1] + tangent[0] * d), d

    def _lane_rule_bounds(self, track: Track, kart: KartView) -> tuple[float, float] | None:
        """(lowest, highest) lateral offset [m] the kart may steer for on the straight it drives without breaking
        eq. (11) gen_lane_lim: the kart itself is to stay within the lanes its remaining changes reach from the lane
        it is in (the referee's count as changes happen), ``lane_guard_margin`` inside their outer boundaries, until
        the straight ends. The aim may lie further out by as much as the kart cannot follow before then: pure
        pursuit closes its lateral offset on the aim's with the time constant of its lookahead, so over the time t
        left on the straight it covers 1 - exp(-t / tau) of the way (an aim clamped to the lane outright held the
        kart in it into the curve: it turned in late, and in three of 100 races from a spread start on
        complex-reversed ran into the kart beside it). None: the guard is off, the kart is on a curve (no limit
        there), or every lane is within reach."""
        p = self.params
        assert self._context is not None
        if not p.lane_rule_guard or kart.lane_now <= 0 or not track.section_is_straight(kart.checkpoints_passed):
            return None
        spare = max(self._context.lane_change_limit - kart.lane_changes_now, 0)
        offsets = track.lane_offsets(kart.checkpoints_passed + 1)  # lane 1 leftmost: offsets fall with the lane id
        lanes = len(offsets)
        leftmost, rightmost = max(1, kart.lane_now - spare), min(lanes, kart.lane_now + spare)
        if leftmost == 1 and rightmost == lanes:
            return None
        highest = math.inf if leftmost == 1 else 0.5 * float(offsets[leftmost - 1] + offsets[leftmost - 2])
        lowest = -math.inf if rightmost == lanes else 0.5 * float(offsets[rightmost - 1] + offsets[rightmost])
        highest, lowest = highest - p.lane_guard_margin, lowest + p.lane_guard_margin
        end = kart.checkpoints_passed + 1
        while track.section_is_straight(end) and end < kart.checkpoints_passed + track.n_checkpoints:
            end += 1
        left = (float(track.checkpoint_s[end % track.n_checkpoints]) - kart.progress) % track.length
        speed = max(abs(kart.speed), 1.0)
        tau = max(p.lookahead_time, p.min_lookahead / speed)
        followed = max(-math.expm1(-left / speed / tau), 1e-6)  # the share of the way to the aim covered by the curve
        here = kart.lateral
        if here < highest:
            highest = here + (highest - here) / followed
        if here > lowest:
            lowest = here + (lowest - here) / followed
        return lowest, highest

    def _passing(self, track: Track, me: KartView, others: list[KartView], plan: Plan | None) -> bool:
        """Whether ``me`` is on a straight behind a kart within ``pass_distance`` that drives slower than the racing
        line's speed there (by ``pass_speed_margin``), and its next planned lane clears that kart sideways by
        ``pass_clearance`` (or, with ``pass_on_prediction``, the plan predicts that kart a lane that far from the
        ego's at one of its next two waypoints): a planned pass. (Behind a kart at the line's pace a lane apart is
        just a line: driven exactly, it crossed lanes early into the next curve, an illegal lane change. The kart's
        own speed says nothing here: station keeping holds it to the other's.)"""
        p = self.params
        assert self._line is not None
        if not track.section_is_straight(me.checkpoints_passed):
            return False
        slower = [
            k
            for k in others
            if 0.0 < track.gap(me.progress, k.progress) < p.pass_distance
            and k.speed < p.speed_scale * float(self._line.speed_at(k.progress)) - p.pass_speed_margin
        ]
        if not slower:
            return False
        first, second = self._upcoming(track, me, plan, me.index)
        target = float(track.lane_offsets(first.checkpoint)[first.lane - 1])
        if any(abs(target - k.lateral) >= p.pass_clearance for k in slower):
            return True
        return (
            p.pass_on_prediction
            and plan is not None
            and any(self._predicted_apart(track, (first, second), plan.waypoints.get(k.index, ())) for k in slower)
        )

    def _predicted_apart(self, track: Track, mine: tuple[Waypoint, ...], theirs: tuple[Waypoint, ...]) -> bool:
        """Whether at one of the ego's waypoints ``mine`` the plan predicts the other kart (its waypoints
        ``theirs``) in a lane at least ``pass_clearance`` sideways from the ego's."""
        predicted = {w.checkpoint: w.lane for w in theirs}
        for w in mine:
            lane = predicted.get(w.checkpoint)
            if lane is None:
                continue
            offsets = track.lane_offsets(w.checkpoint)
            if abs(float(offsets[w.lane - 1]) - float(offsets[lane - 1])) >= self.params.pass_clearance:
                return True
        return False

    def _station_limit(
        self,
        kart: KartView,
        others: list[KartView],
        aim_offset: float,
        straight: bool = True,
        track: Track | None = None,
    ) -> float:
        """Highest speed [m/s] that keeps station behind the nearest kart ahead in ``kart``'s path (inf: none):
        within ``follow_band`` of it sideways, or within ``follow_path_band`` of ``aim_offset``, the lateral offset
        it steers for (a kart pulling out to pass leaves the other behind it; one cutting in behind does not); with
        ``follow_predict_time`` and the ``track``, also one that drifts that close within that time. With
        ``yield_speed_margin`` as well, a faster kart cutting across from alongside caps it under its own speed
        (it brakes to let that kart in).

        Ahead and aside are measured in the kart's own heading frame (in a hairpin the centre line's progress
        says little about the distance between two karts)."""
        p = self.params
        limit = math.inf
        cos_h, sin_h = math.cos(kart.heading), math.sin(kart.heading)
        predict = track is not None and p.follow_predict_time > 0.0
        my_rate: float | None = None  # across the track, looked up once and only if a drift is predicted

        def drifts_into_path(other: KartView, aside: float) -> bool:
            """Whether the two karts' rates across the track take ``other`` (``aside`` m to the side) across the
            kart's line or within ``follow_band`` of it within ``follow_predict_time``."""
            nonlocal my_rate
            assert track is not None
            if my_rate is None:
                my_rate = _rate_across(track, kart)
            then = aside + (_rate_across(track, other) - my_rate) * p.follow_predict_time
            return aside * then <= 0.0 or abs(then) < p.follow_band

        for other in others:
            dx, dy = other.x - kart.x, other.y - kart.y
            ahead = dx * cos_h + dy * sin_h
            aside = -dx * sin_h + dy * cos_h
            if (
                predict
                and p.yield_speed_margin > 0.0
                and other.speed > kart.speed + p.yield_speed_margin
                and -p.alongside_reach < ahead < p.follow_distance
                and drifts_into_path(other, aside)
            ):
                limit = min(limit, max(kart.speed - p.yield_drop, 0.0))
            if ahead <= p.follow_min_ahead:
                continue
            in_path = abs(aside) < p.follow_band or abs(other.lateral - aim_offset) < p.follow_path_band
            if not in_path and predict:
                in_path = drifts_into_path(other, aside)
            if not in_path:
                continue
            if p.follow_safe_braking > 0.0:
                standoff = p.follow_distance if straight or p.follow_distance_curve <= 0.0 else p.follow_distance_curve
                limit = min(limit, self._safe_speed(ahead - standoff, other.speed))
                continue
            gap = ahead - (p.follow_distance + p.follow_time * kart.speed)
            limit = min(limit, max(other.speed + p.follow_gain * gap, 0.0))
        return limit

    def _alongside_bounds(self, track: Track, me: KartView, others: list[KartView]) -> tuple[float, float] | None:
        """(lowest, highest) lateral offset [m] the kart may steer for with karts alongside (``alongside_clearance``
        sideways from each, or ``alongside_push`` further from it than the kart is now where the two are closer
        than that); None: off, or no kart alongside."""
        p = self.params
        if p.alongside_clearance <= 0.0:
            return None
        lowest, highest = -math.inf, math.inf
        for other in others:
            if abs(track.gap(me.progress, other.progress)) >= p.alongside_reach:
                continue
            if other.lateral < me.lateral:  # on the right
                lowest = max(lowest, min(other.lateral + p.alongside_clearance, me.lateral + p.alongside_push))
            elif other.lateral > me.lateral:
                highest = min(highest, max(other.lateral - p.alongside_clearance, me.lateral - p.alongside_push))
        if lowest == -math.inf and highest == math.inf:
            return None
        if lowest > highest:  # a kart on each side: hold the line between them
            return me.lateral, me.lateral
        return lowest, highest

    def _safe_speed(self, room_ahead: float, other_speed: float) -> float:
        """Gipps' safe speed [m/s] behind a kart at ``other_speed`` with ``room_ahead`` m to spare beyond the
        standoff: the highest v with v * tau + v^2 / 2b <= room_ahead + other_speed^2 / 2b (tau: ``follow_time``,
        b: ``follow_safe_braking``)."""
        p = self.params
        b, tau = p.follow_safe_braking, p.follow_time
        room = (b * tau) ** 2 + other_speed**2 + 2.0 * b * room_ahead
        return max(math.sqrt(room) - b * tau, 0.0) if room > 0.0 else 0.0

    def _speed_target(self, kart: KartView, first: Waypoint, second: Waypoint, top: float, brake: float) -> float:
        p = self.params
        assert self._line is not None and self._context is not None
        # never faster than the racing line's speed profile here (it already brakes for the corners ahead)
        here = self._line.speed_at(kart.progress)
        target = min(top, float(here))
        for w in (first, second):
            dist = math.hypot(w.position[0] - kart.x, w.position[1] - kart.y)
            allowed = math.sqrt((min(w.speed + p.speed_margin, top)) ** 2 + 2.0 * brake * p.braking_use * dist)
            target = min(target, allowed)
        return target

    # ------------------------------------------------------------------ control
    def act(self, observation: Observation, plan: Plan | None) -> Action:
        """Solve the game at the current state and map the ego's first control to steer and throttle."""
        assert self._context is not None, "reset() first"
        ctx = self._context
        track, kart = ctx.track, ctx.kart
        w = self.params.weights
        me = observation.me
        others = [k for k in observation.others() if math.hypot(k.x - me.x, k.y - me.y) < w.avoid_radius]
        players = [me, *others]
        tolerance = self.params.traffic_lane_tolerance if others else self.params.lane_tolerance
        alongside = any(abs(track.gap(me.progress, k.progress)) < self.params.alongside_distance for k in others)
        if alongside or (self.params.pass_distance > 0.0 and self._passing(track, me, others, plan)):
            tolerance = 0.0
        x0 = np.zeros(STATE_SIZE * len(players))
        targets = []
        station = math.inf
        for i, k in enumerate(players):
            # positions relative to the ego kart keep the numbers small
            x0[STATE_SIZE * i : STATE_SIZE * i + 3] = (k.x - me.x, k.y - me.y, k.speed)
            first, second = self._upcoming(track, k, plan, k.index)
            bounds = (
                _within(self._lane_rule_bounds(track, k), self._alongside_bounds(track, k, others)) if i == 0 else None
            )
            ax, ay, aim_offset = self._aim(track, k, first, second, tolerance, bounds)
            heading_error = math.remainder(math.atan2(ay - k.y, ax - k.x) - k.heading, 2.0 * math.pi)
            speed = self._speed_target(k, first, second, kart.top_speed, kart.braking)
            if i == 0:
                if self.params.follow_gain > 0.0:
                    # only the curve standoff of the safe-speed rule needs the section (not looked up per step else)
                    straight = self.params.follow_distance_curve <= 0.0 or track.section_is_straight(
                        me.checkpoints_passed
                    )
                    station = self._station_limit(me, others, aim_offset, straight, track)
                speed = min(speed * self.params.speed_scale, station)
            targets.append((first.position[0] - me.x, first.position[1] - me.y, speed, heading_error))
        P, alpha = self._solve(players, targets, plan)
        accel, yaw_rate = -(P[0][0:2] @ x0) - alpha[0][0:2]
        if me.speed > station:
            # closing on the kart ahead: brake at once (the LQ speed weight is too soft for it)
            accel = min(float(accel), -self.params.follow_brake_gain * (me.speed - station))
        throttle = throttle_for_acceleration(self._kart_vector, me.speed, float(accel))
        speed = max(abs(me.speed), 1.0)
        steer = min(max(math.atan(yaw_rate * kart.wheelbase / speed) / kart.max_steer_angle, -1.0), 1.0)
        if self.params.grip_steer > 0.0 and not self._beside(track, me, others):
            held = self._grip_steer(me)
            steer = min(max(steer, -held), held)
        if self.params.steer_rate > 0.0:
            step = self.params.steer_rate * DT
            steer = min(max(steer, self._steer - step), self._steer + step)
        self._steer = steer
        return Action(steer, min(max(float(throttle), -1.0), 1.0))

    @property
    def last_steer(self) -> float:
        """The steer last sent, from which ``steer_rate`` limits the next (the tracker's only memory)."""
        return self._steer

    @last_steer.setter
    def last_steer(self, steer: float) -> None:
        self._steer = steer

    def start_steering(self, observation: Observation, plan: Plan | None) -> float:
        """Take the steer the tracker asks for at ``observation`` as its last steer, with no rate limit, and return
        it: a tracker started mid-race (a planner's rollout, :mod:`controllers.rollout_check`) would otherwise
        steer from straight ahead at ``steer_rate``, and run wide out of a corner it is already in."""
        held = self.params
        self.params = replace(held, steer_rate=0.0)
        try:
            return self.act(observation, plan).steer
        finally:
            self.params = held

    def _beside(self, track: Track, me: KartView, others: list[KartView]) -> bool:
        """Whether a kart is alongside ``me`` (within ``alongside_distance`` along the track) and within
        ``grip_steer_clearance`` sideways."""
        p = self.params
        return any(
            abs(track.gap(me.progress, k.progress)) < p.alongside_distance
            and abs(k.lateral - me.lateral) < p.grip_steer_clearance
            for k in others
        )

    def _grip_steer(self, me: KartView) -> float:
        """The steer input [-1, 1] whose path curvature (the kart model's bicycle,
        :func:`sim_core.kart.kart_step`) is ``grip_steer`` of what the tyres hold at ``me``'s speed and wear."""
        assert self._context is not None
        kart = self._context.kart
        speed = max(abs(me.speed), 1e-3)
        curvature = self.params.grip_steer * lateral_limit(self._kart_vector, me.wear) / (speed * speed)
        sin_beta = min(0.5 * kart.wheelbase * curvature, 0.999)
        tan_delta = 2.0 * sin_beta / math.sqrt(1.0 - sin_beta * sin_beta)
        return min(math.atan(tan_delta) / kart.max_steer_angle, 1.0)

    def _solve(
        self, players: list[KartView], targets: list[tuple[float, float, float, float]], plan: Plan | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The game's feedback Nash gains (``P``, ``alpha``), eq. (23) lqng_obj for every player: its waypoint
        (20) paid, the separation from each other player (22) earned, and for the ego alone the denial (21) of
        each opponent's predicted waypoint. The opponents are assumed to play the same game with their own
        avoidance scale and no denial."""
        w = self.params.weights
        me = players[0]
        count = len(players)
        separation = np.zeros((count, count))
        denied = np.zeros(count, dtype=np.bool_)
        for i, k in enumerate(players):
            scale = w.avoid_scale if i == 0 else w.opponent_avoid_scale
            for j, other in enumerate(players):
                if j != i:
                    dist = max(math.hypot(other.x - k.x, other.y - k.y), 0.5)
                    separation[i, j] = 1.0 / (dist**1.5 * scale)
            denied[i] = i > 0 and plan is not None and k.index in plan.waypoints
        return solve_tracker_game(
            np.array([k.heading for k in players]),
            np.array([k.speed for k in players]),
            np.array(targets),
            np.array([w.position / max(1.0, k.speed) for k in players]),
            w.speed,
            w.heading,
            separation,
            denied,
            w.deny / max(1.0, me.speed),
            w.control,
            DT,
            self.params.horizon,
        )
