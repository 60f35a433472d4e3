"""The RL tracker's sideways shield: never move across into a kart alongside (ours, not the paper's).

The referee charges a contact between karts alongside to each kart that was moving sideways toward the other
(:func:`sim_core.referee.charge_contact`). The policies were trained against one opponent and, in fields of
eight, steer into karts beside them: of 85 collisions at fault in six 8-kart races, 57 were side contacts, most of
them an RL kart's. :class:`SideRoomShield` bounds the ego's course against the track: with a kart within
``reach`` along the track and ``zone`` across, the ego's own sideways speed toward it may be at most the speed from
which turning away at a share of the tyres' grip stops closing at ``clearance`` across (centre to centre; the
referee charges a sideways speed over 0.3 m/s). A steer that would take the course past that bound within
``settle_time`` is replaced by the steer that reaches the bound; the pedal stays the policy's. A kart on each
side: hold the track's direction.

The ego's course (heading plus slip: the direction it travels, which the referee judges) is not observed: it is
measured from the kart's displacement since the shield's previous decision.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from controllers.base import Action
from sim_core.observation import KartView
from sim_core.params import GRAVITY, KartParams
from sim_core.track import Track


@dataclass(frozen=True)
class CourseBounds:
    """The ego's allowed course against the track's direction [rad] (left-positive), ``low`` to ``high``."""

    low: float
    high: float


@dataclass(frozen=True)
class SideRoomShield:
    """Bound the ego's sideways motion toward karts alongside (see the module)."""

    wheelbase: float  # [m]
    max_steer: float  # [rad] the front wheels' angle at full lock
    lateral_grip: float  # [m/s^2] the fresh tyres' lateral limit: the sharpest course change a steer can make
    reach: float = 4.0  # [m] centres closer than this along the track: alongside or about to be
    zone: float = 5.0  # [m] ... and closer than this across
    clearance: float = 1.1  # [m] the centre-to-centre gap across the ego closes no further (a body width: 0.9)
    lateral_use: float = 0.4  # the share of the fresh tyres' grip the ego plans to turn away with
    settle_time: float = 0.2  # [s] how far ahead the course under the policy's steer is judged
    response_time: float = 0.1  # [s] over which a course outside the bounds is brought back
    turn_use: float = 0.8  # the share of the fresh tyres' grip it turns back with at most

    @classmethod
    def of(cls, kart: KartParams, clearance: float = 1.1) -> SideRoomShield:
        """The shield for ``kart``."""
        return cls(kart.wheelbase, kart.max_steer_angle, kart.lateral_g_fresh * GRAVITY, clearance=clearance)

    def closing_limit(self, across: float) -> float:
        """The ego's highest sideways speed [m/s] toward a kart ``across`` [m] away (centre to centre): the speed
        from which turning away at ``lateral_use`` of the grip stops closing at the clearance (none inside it)."""
        room = max(abs(across) - self.clearance, 0.0)
        return math.sqrt(2.0 * self.lateral_use * self.lateral_grip * room)

    def bounds(self, me: KartView, others: Iterable[KartView], track: Track) -> CourseBounds | None:
        """The course the ego may hold against the track's direction; None with nobody alongside."""
        speed = max(me.speed, 1e-3)
        low, high = -math.inf, math.inf
        for other in others:
            if other.index == me.index or other.finished:
                continue
            if abs(track.gap(me.progress, other.progress)) >= self.reach:
                continue
            across = other.lateral - me.lateral
            if abs(across) >= self.zone:
                continue
            angle = math.asin(min(self.closing_limit(across) / speed, 1.0))
            if across > 0.0:  # on the left: the course may turn left by at most ``angle``
                high = min(high, angle)
            else:
                low = max(low, -angle)
        if low == -math.inf and high == math.inf:
            return None
        if low > high:  # a kart on each side: hold the track's direction
            return CourseBounds(0.0, 0.0)
        return CourseBounds(low, high)

    def limit(self, action: Action, me: KartView, course: float, others: Iterable[KartView], track: Track) -> Action:
        """``action`` with its steer replaced where the course it leads to within ``settle_time`` leaves
        :meth:`bounds` (``course``: the ego's measured direction of travel [rad])."""
        if me.speed < 1.0:
            return action
        bounds = self.bounds(me, others, track)
        if bounds is None:
            return action
        _, tangent = track.point_at(me.progress)
        track_heading = math.atan2(float(tangent[1]), float(tangent[0]))
        travel = me.speed * self.settle_time
        _, tangent_then = track.point_at(me.progress + travel)
        heading_then = math.atan2(float(tangent_then[1]), float(tangent_then[0]))
        track_turn = math.remainder(heading_then - track_heading, math.tau)
        relative = math.remainder(course - track_heading, math.tau)
        then = relative + self._course_turn(action.steer, me.speed) * self.settle_time - track_turn
        if bounds.low <= then <= bounds.high and bounds.low <= relative <= bounds.high:
            return action
        target = min(max(then, bounds.low), bounds.high)
        # the course turn rate that brings the course to the bound within the response time (on top of the
        # track's own turn), at most ``turn_use`` of the grip; then the steer of the steady bicycle that turns so
        rate = (target - relative) / self.response_time + track_turn / self.settle_time
        most = self.turn_use * self.lateral_grip / me.speed
        steer = self._steer_for(min(max(rate, -most), most), me.speed)
        # never toward the bound's side beyond what the policy asked; the pedal stays the policy's (braking as well
        # was tried: in 8-kart fields it traded side contacts for rear-end ones behind the braking kart)
        over_high = then > bounds.high or (then >= bounds.low and relative > bounds.high)
        away = min(steer, action.steer) if over_high else max(steer, action.steer)
        return Action(away, action.throttle)

    def _course_turn(self, steer: float, speed: float) -> float:
        """The course's turn rate [rad/s] a steady ``steer`` gives at ``speed`` (the tyres' limit included)."""
        tan_beta = 0.5 * math.tan(max(min(steer, 1.0), -1.0) * self.max_steer)
        curvature = 2.0 * tan_beta / math.sqrt(1.0 + tan_beta * tan_beta) / self.wheelbase
        limit = self.lateral_grip / (speed * speed)
        return speed * max(min(curvature, limit), -limit)

    def _steer_for(self, rate: float, speed: float) -> float:
        """The steer command in [-1, 1] whose steady course turn rate is ``rate`` [rad/s] at ``speed``."""
        sin_beta = max(min(0.5 * self.wheelbase * rate / speed, 1.0), -1.0)
        tan_beta = sin_beta / math.sqrt(max(1.0 - sin_beta * sin_beta, 1e-12))
        return max(min(math.atan(2.0 * tan_beta) / self.max_steer, 1.0), -1.0)
