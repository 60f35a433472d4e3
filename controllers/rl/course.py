"""Steering the RL tracker's course within bounds: the shared part of its sideways shields (ours, not the paper's).

A shield says which course against the track's direction the ego may hold (:class:`CourseBounds`: a kart alongside
on one side, a lane boundary it may not cross on the other); :class:`CourseSteer` keeps the policy's steer where the
course it leads to stays within them and otherwise replaces it by the steer that brings the course to the nearer
bound. How far a bound lies is a sideways speed: the speed toward something ``room`` metres across from which
turning away at a share of the tyres' grip stops closing on it (:meth:`CourseSteer.course_toward`).

The ego's course (heading plus slip: the direction it travels, which the referee judges) is not observed: the
filters measure it from the kart's displacement between decisions.
"""

from __future__ import annotations

import math
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
class CourseSteer:
    """Keep the course within bounds by steering (see the module); the pedal is never touched."""

    wheelbase: float  # [m]
    max_steer: float  # [rad] the front wheels' angle at full lock
    lateral_grip: float  # [m/s^2] the fresh tyres' lateral limit: the sharpest course change a steer can make
    lateral_use: float = 0.4  # the share of the fresh tyres' grip the ego plans to turn away with
    settle_time: float = 0.2  # [s] how far ahead the course under the policy's steer is judged
    response_time: float = 0.1  # [s] over which a course outside the bounds is brought back
    turn_use: float = 0.8  # the share of the fresh tyres' grip it turns back with at most

    @classmethod
    def of(cls, kart: KartParams) -> CourseSteer:
        """The course steer of ``kart``."""
        return cls(kart.wheelbase, kart.max_steer_angle, kart.lateral_g_fresh * GRAVITY)

    def closing_limit(self, room: float) -> float:
        """The highest sideways speed [m/s] toward something ``room`` [m] away across: the speed from which turning
        away at ``lateral_use`` of the grip stops closing before it (none with no room)."""
        return math.sqrt(2.0 * self.lateral_use * self.lateral_grip * max(room, 0.0))

    def course_toward(self, room: float, speed: float) -> float:
        """The largest course angle [rad] toward something ``room`` [m] away across, at ``speed`` [m/s]."""
        return math.asin(min(self.closing_limit(room) / max(speed, 1e-3), 1.0))

    def limit(self, action: Action, me: KartView, course: float, bounds: CourseBounds, track: Track) -> Action:
        """``action`` with its steer replaced where the course it leads to within ``settle_time`` leaves ``bounds``
        (``course``: the ego's measured direction of travel [rad]); unchanged below 1 m/s."""
        if me.speed < 1.0:
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
