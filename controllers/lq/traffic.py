"""Traffic rules of the LQNG tracker (ours, not the paper's): small named parts, each with its own frozen
parameters, that a preset composes as a tuple, the way HighwayEnv names IDM and MOBIL.

The paper's LQ game (eqs. (20)-(24)) tracks waypoints and keeps apart through its separation cost alone; with
coarse tactical plans that left the karts touching in traffic. Each rule here adds one driver's habit at one
point of :meth:`controllers.lq.tracker.LQNGTracker.act`, and has a role (a Protocol) that says where:

* :class:`ExactLanes` — whether the planned lanes are driven exactly this step instead of blended toward the
  racing line (:class:`LanesExactAlongside`, :class:`PassDetector`);
* :class:`LateralBound` — the lateral offsets the ego may steer for (:class:`LaneRuleGuard`,
  :class:`AlongsideDiscipline`); bounds are intersected in the preset's order, and where two do not overlap the
  earlier rule's stand;
* :class:`SpeedLimit` — a speed the ego brakes to (:class:`StationKeeping`, :class:`Yield`);
* :class:`SteerFilter` — the steer sent, given the last one (:class:`SteerRateLimit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

from controllers.plan import Plan, Waypoint
from controllers.racing_line import RacingLine
from sim_core.observation import KartView
from sim_core.params import DT
from sim_core.track import Track


@dataclass(frozen=True)
class TrafficScene:
    """What the traffic rules see at one step of the ego's tracker."""

    track: Track
    me: KartView
    others: list[KartView]  # the karts within the LQ game's reach (``LQNGWeights.avoid_radius``)
    plan: Plan | None
    line: RacingLine  # the tracker's racing line (its speed profile says how fast a kart drives in clean air)
    upcoming: tuple[Waypoint, Waypoint]  # the ego's next two waypoints
    lane_change_limit: int  # L of eq. (11) gen_lane_lim
    speed_scale: float  # the fraction of its speed targets the ego drives at
    lookahead_time: float  # [s] the tracker's pure-pursuit lookahead is max(min_lookahead, speed x this) ...
    min_lookahead: float  # [m] ... so it closes on its aim with the time constant max(this / speed, the time)


@runtime_checkable
class ExactLanes(Protocol):
    """A rule that makes the tracker drive the planned lanes exactly (no blending toward the racing line)."""

    def exact_lanes(self, scene: TrafficScene) -> bool:
        """Whether the planned lanes are driven exactly this step."""
        ...


@runtime_checkable
class LateralBound(Protocol):
    """A rule that bounds the lateral offset the ego steers for."""

    def bounds(self, scene: TrafficScene) -> tuple[float, float] | None:
        """(lowest, highest) lateral offset [m] allowed, or None: no bound this step."""
        ...


@runtime_checkable
class SpeedLimit(Protocol):
    """A rule that caps the ego's speed target (the tracker brakes to it at once when over it)."""

    def speed_limit(self, scene: TrafficScene, aim_offset: float) -> float:
        """The highest speed [m/s] allowed (inf: none); ``aim_offset`` is the lateral offset the ego steers for."""
        ...


@runtime_checkable
class SteerFilter(Protocol):
    """A rule on the steer input sent."""

    def filter_steer(self, steer: float, last_steer: float) -> float:
        """The steer to send, given the tracker's ``steer`` and the one sent at the step before."""
        ...


TrafficRule = ExactLanes | LateralBound | SpeedLimit | SteerFilter


def rate_across(track: Track, kart: KartView) -> float:
    """The kart's velocity across the track [m/s], left-positive, from its heading against the centre line's."""
    _, tangent = track.point_at(kart.progress)
    return kart.speed * (math.sin(kart.heading) * float(tangent[0]) - math.cos(kart.heading) * float(tangent[1]))


def _drifts_into_path(
    scene: TrafficScene, other: KartView, aside: float, band: float, predict_time: float, my_rate: list[float]
) -> bool:
    """Whether the two karts' rates across the track take ``other`` (``aside`` m to the side) across the ego's line
    or within ``band`` of it within ``predict_time``; ``my_rate`` caches the ego's rate (looked up once, if ever)."""
    if not my_rate:
        my_rate.append(rate_across(scene.track, scene.me))
    then = aside + (rate_across(scene.track, other) - my_rate[0]) * predict_time
    return aside * then <= 0.0 or abs(then) < band


def _ahead_and_aside(me: KartView, other: KartView) -> tuple[float, float]:
    """``other``'s position in ``me``'s heading frame [m] (in a hairpin the centre line's progress says little about
    the distance between two karts)."""
    cos_h, sin_h = math.cos(me.heading), math.sin(me.heading)
    dx, dy = other.x - me.x, other.y - me.y
    return dx * cos_h + dy * sin_h, -dx * sin_h + dy * cos_h


@dataclass(frozen=True)
class LanesExactAlongside:
    """With another kart closer than ``distance`` along the track (alongside), drive the planned lanes exactly:
    two karts blending onto one racing line would touch."""

    distance: float = 4.0  # [m]

    def exact_lanes(self, scene: TrafficScene) -> bool:
        """Whether a kart is alongside."""
        return any(abs(scene.track.gap(scene.me.progress, k.progress)) < self.distance for k in scene.others)


@dataclass(frozen=True)
class PassDetector:
    """A planned pass is driven exactly: on a straight, behind a kart within ``distance`` that drives slower than
    the racing line there (by ``speed_margin``), with the next planned lane clear of it sideways by ``clearance``
    (or, with ``on_prediction``, the plan predicting that kart a lane that far from the ego's at one of its next
    two waypoints). Blended toward the line, the ego stayed in the other's wake, held back by station keeping.
    (Behind a kart at the line's pace a lane apart is just a line: driven exactly, it crossed lanes early into
    the next curve, an illegal lane change.)"""

    distance: float = 10.0  # [m]
    clearance: float = 1.5  # [m]
    speed_margin: float = 0.3  # [m/s]
    on_prediction: bool = True

    def exact_lanes(self, scene: TrafficScene) -> bool:
        """Whether the plan is a pass now."""
        track, me = scene.track, scene.me
        if not track.section_is_straight(me.checkpoints_passed):
            return False
        slower = [
            k
            for k in scene.others
            if 0.0 < track.gap(me.progress, k.progress) < self.distance
            and k.speed < scene.speed_scale * float(scene.line.speed_at(k.progress)) - self.speed_margin
        ]
        if not slower:
            return False
        first, second = scene.upcoming
        target = float(track.lane_offsets(first.checkpoint)[first.lane - 1])
        if any(abs(target - k.lateral) >= self.clearance for k in slower):
            return True
        plan = scene.plan
        return (
            self.on_prediction
            and plan is not None
            and any(self.predicted_apart(track, (first, second), plan.waypoints.get(k.index, ())) for k in slower)
        )

    def predicted_apart(self, track: Track, mine: tuple[Waypoint, ...], theirs: tuple[Waypoint, ...]) -> bool:
        """Whether at one of the ego's waypoints ``mine`` the plan predicts the other kart (its waypoints
        ``theirs``) in a lane at least ``clearance`` sideways from the ego's."""
        predicted = {w.checkpoint: w.lane for w in theirs}
        for w in mine:
            lane = predicted.get(w.checkpoint)
            if lane is None:
                continue
            offsets = track.lane_offsets(w.checkpoint)
            if abs(float(offsets[w.lane - 1]) - float(offsets[lane - 1])) >= self.clearance:
                return True
        return False


@dataclass(frozen=True)
class LaneRuleGuard:
    """On a straight with its lane changes spent (eq. (11) gen_lane_lim, counted as they happen), steer for no
    point beyond the lanes the changes left reach, ``margin`` short of their outer boundaries, until the curve:
    blending toward the line and the next curve's lane otherwise crosses a boundary before the curve begins.

    The aim may lie further out by as much as the kart cannot follow before then: pure pursuit closes its lateral
    offset on the aim's with the time constant of its lookahead, so over the time t left on the straight it
    covers 1 - exp(-t / tau) of the way (an aim clamped to the lane outright held the kart in it into the curve:
    it turned in late, and ran into a kart beside it)."""

    margin: float = 0.2  # [m]

    def bounds(self, scene: TrafficScene) -> tuple[float, float] | None:
        """The offsets the lanes within reach allow; None on a curve, before the first lane is known, or with
        every lane within reach."""
        track, kart = scene.track, scene.me
        if kart.lane_now <= 0 or not track.section_is_straight(kart.checkpoints_passed):
            return None
        spare = max(scene.lane_change_limit - kart.lane_changes_now, 0)
        offsets = track.lane_offsets(kart.checkpoints_passed + 1)  # lane 1 leftmost: offsets fall with the lane id
        lanes = len(offsets)
        leftmost, rightmost = max(1, kart.lane_now - spare), min(lanes, kart.lane_now + spare)
        if leftmost == 1 and rightmost == lanes:
            return None
        highest = math.inf if leftmost == 1 else 0.5 * float(offsets[leftmost - 1] + offsets[leftmost - 2])
        lowest = -math.inf if rightmost == lanes else 0.5 * float(offsets[rightmost - 1] + offsets[rightmost])
        highest, lowest = highest - self.margin, lowest + self.margin
        end = kart.checkpoints_passed + 1
        while track.section_is_straight(end) and end < kart.checkpoints_passed + track.n_checkpoints:
            end += 1
        left = (float(track.checkpoint_s[end % track.n_checkpoints]) - kart.progress) % track.length
        speed = max(abs(kart.speed), 1.0)
        tau = max(scene.lookahead_time, scene.min_lookahead / speed)
        followed = max(-math.expm1(-left / speed / tau), 1e-6)  # the share of the way to the aim covered by the curve
        here = kart.lateral
        if here < highest:
            highest = here + (highest - here) / followed
        if here > lowest:
            lowest = here + (lowest - here) / followed
        return lowest, highest


@dataclass(frozen=True)
class AlongsideDiscipline:
    """With another kart alongside (centres closer than ``reach`` along the track), steer for no offset nearer to
    it sideways than ``clearance`` (centre to centre), and where the two are already closer, for one no nearer than
    the present offset plus ``push``: the kart that moves sideways into another alongside is at fault (the
    referee's alongside rule), and a line that runs out of a corner across the other kart's does exactly that."""

    clearance: float = 1.5  # [m]
    reach: float = 2.5  # [m] a body length (2 m) and a margin
    push: float = 0.2  # [m]

    def bounds(self, scene: TrafficScene) -> tuple[float, float] | None:
        """The offsets clear of every kart alongside; the kart's own offset with one on each side; None: nobody
        alongside."""
        me = scene.me
        lowest, highest = -math.inf, math.inf
        for other in scene.others:
            if abs(scene.track.gap(me.progress, other.progress)) >= self.reach:
                continue
            if other.lateral < me.lateral:  # on the right
                lowest = max(lowest, min(other.lateral + self.clearance, me.lateral + self.push))
            elif other.lateral > me.lateral:
                highest = min(highest, max(other.lateral - self.clearance, me.lateral - self.push))
        if lowest == -math.inf and highest == math.inf:
            return None
        if lowest > highest:  # a kart on each side: hold the line between them
            return me.lateral, me.lateral
        return lowest, highest


@dataclass(frozen=True)
class StationKeeping:
    """Keep station behind the nearest kart ahead in the ego's path.

    In the path: ahead by more than ``min_ahead`` (closer is alongside: lane discipline keeps the two apart) and
    within ``band`` of the ego sideways, or within ``path_band`` of the offset it steers for (a kart pulling out
    to pass leaves the other behind it; one cutting in behind does not), or, with ``predict_time``, drifting that
    close within that time at both karts' present rates across the track (a kart drifting over in front is
    braked for before it is there).

    ``kind`` ``"linear"``: at most the other's speed plus ``gain`` times the gap beyond ``distance`` + ``time`` x
    speed. ``"gipps"``: the safe speed of Gipps' car-following model, fast enough to stop ``distance`` short of
    where the kart ahead would stop, both braking at ``safe_braking``, this one after ``time`` at its speed
    (``distance_curve`` in curves): it closes up on a slower kart where braking leaves room, and dives inside at
    the straight's end."""

    kind: Literal["linear", "gipps"] = "linear"
    distance: float = 3.0  # [m] centre to centre (a kart length and a margin)
    time: float = 0.25  # [s]
    band: float = 1.6  # [m]
    path_band: float = 0.0  # [m] 0: only the kart's own band counts
    gain: float = 1.0  # [1/s] linear
    safe_braking: float = 6.0  # [m/s^2] gipps
    distance_curve: float = 0.0  # [m] gipps: > 0, the standoff in curves
    min_ahead: float = 1.0  # [m]
    predict_time: float = 0.0  # [s] 0: no drift prediction

    @classmethod
    def gipps(cls, **settings: float) -> StationKeeping:
        """Station keeping by Gipps' safe speed."""
        return cls(kind="gipps", **settings)  # type: ignore[arg-type]

    @classmethod
    def linear(cls, **settings: float) -> StationKeeping:
        """Station keeping by a linear gap rule."""
        return cls(kind="linear", **settings)  # type: ignore[arg-type]

    def speed_limit(self, scene: TrafficScene, aim_offset: float) -> float:
        """The highest speed [m/s] that keeps station behind the nearest kart in the path (inf: none)."""
        me, track = scene.me, scene.track
        limit = math.inf
        my_rate: list[float] = []
        straight = self.distance_curve <= 0.0 or track.section_is_straight(me.checkpoints_passed)
        for other in scene.others:
            ahead, aside = _ahead_and_aside(me, other)
            if ahead <= self.min_ahead:
                continue
            in_path = abs(aside) < self.band or abs(other.lateral - aim_offset) < self.path_band
            if not in_path and self.predict_time > 0.0:
                in_path = _drifts_into_path(scene, other, aside, self.band, self.predict_time, my_rate)
            if not in_path:
                continue
            if self.kind == "gipps":
                standoff = self.distance if straight or self.distance_curve <= 0.0 else self.distance_curve
                limit = min(limit, self.safe_speed(ahead - standoff, other.speed))
                continue
            gap = ahead - (self.distance + self.time * me.speed)
            limit = min(limit, max(other.speed + self.gain * gap, 0.0))
        return limit

    def safe_speed(self, room_ahead: float, other_speed: float) -> float:
        """Gipps' safe speed [m/s] behind a kart at ``other_speed`` with ``room_ahead`` m to spare beyond the
        standoff: the highest v with v * tau + v^2 / 2b <= room_ahead + other_speed^2 / 2b (tau: ``time``,
        b: ``safe_braking``)."""
        b, tau = self.safe_braking, self.time
        room = (b * tau) ** 2 + other_speed**2 + 2.0 * b * room_ahead
        return max(math.sqrt(room) - b * tau, 0.0) if room > 0.0 else 0.0


@dataclass(frozen=True)
class Yield:
    """Let a passing kart in: one at least ``speed_margin`` faster, alongside (within ``reach`` behind) or less
    than ``ahead`` in front, that the two karts' rates across the track bring within ``band`` sideways within
    ``predict_time``, is braked for at once (a limit ``drop`` under the ego's speed). Such a kart cuts in a body
    length ahead, and the contact is the follower's fault; station keeping starts only once it is ahead, too
    late."""

    speed_margin: float = 2.0  # [m/s]
    drop: float = 0.6  # [m/s]
    reach: float = 2.5  # [m]
    ahead: float = 3.0  # [m]
    band: float = 1.6  # [m]
    predict_time: float = 0.4  # [s]

    def speed_limit(self, scene: TrafficScene, aim_offset: float) -> float:
        """Just under the ego's speed while a faster kart cuts in; inf otherwise."""
        me = scene.me
        limit = math.inf
        my_rate: list[float] = []
        for other in scene.others:
            ahead, aside = _ahead_and_aside(me, other)
            if (
                other.speed > me.speed + self.speed_margin
                and -self.reach < ahead < self.ahead
                and _drifts_into_path(scene, other, aside, self.band, self.predict_time, my_rate)
            ):
                limit = min(limit, max(me.speed - self.drop, 0.0))
        return limit


@dataclass(frozen=True)
class SteerRateLimit:
    """The steering input changes at most ``rate`` per second (lock to lock in 2 / rate s): it clips the rare
    jumps of the solved input (up to 50/s where a new plan or a kart entering the game moves the aim point), a
    full-lock zig-zag that traction control turns into braking."""

    rate: float = 5.0  # [1/s]

    def filter_steer(self, steer: float, last_steer: float) -> float:
        """``steer`` within ``rate`` x DT of ``last_steer``."""
        step = self.rate * DT
        return min(max(steer, last_steer - step), last_steer + step)
