"""The RL tracker's sideways shields (ours, not the paper's): never move across into a kart alongside, and never
cross into a lane the lane-change rule no longer allows.

* :class:`SideRoomShield`: the referee charges a contact between karts alongside to each kart that was moving
  sideways toward the other (:func:`sim_core.referee.charge_contact`). The policies were trained against one
  opponent and, in fields of eight, steer into karts beside them: of 85 collisions at fault in six 8-kart races, 57
  were side contacts, most of them an RL kart's. With a kart within ``reach`` along the track and ``zone`` across,
  the ego's sideways speed toward it may be at most the speed from which turning away stops closing at
  ``clearance`` across (centre to centre; the referee charges a sideways speed over 0.3 m/s). A kart on each side:
  hold the track's direction.
* :class:`LaneLimitShield`: on a straight whose lane changes the kart has spent (eq. (11) gen_lane_lim, counted as
  they happen: the referee's own counter, in the observation), the kart's sideways speed toward the boundary of the
  lanes it may still reach is bounded the same way, the boundary being where the referee's lane membership changes
  (``lane_hysteresis`` past the midpoint between two lanes) less ``margin``. A fixed racing line can ask for more
  changes on one straight than the rule allows (``fixed-rl`` on ``oval``'s back straight: four where three are
  allowed); the shield holds the kart in its lane until the curve, where changes are free.

Both only bound the course (:class:`~controllers.rl.course.CourseSteer`); the pedal stays the policy's.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from controllers.rl.course import CourseBounds, CourseSteer
from sim_core.observation import KartView
from sim_core.params import KartParams, RuleParams
from sim_core.track import Track


@dataclass(frozen=True)
class SideRoomShield:
    """Bound the ego's sideways motion toward karts alongside (see the module)."""

    steer: CourseSteer
    reach: float = 4.0  # [m] centres closer than this along the track: alongside or about to be
    zone: float = 5.0  # [m] ... and closer than this across
    clearance: float = 1.1  # [m] the centre-to-centre gap across the ego closes no further (a body width: 0.9)

    @classmethod
    def of(cls, kart: KartParams, clearance: float = 1.1) -> SideRoomShield:
        """The shield for ``kart``."""
        return cls(CourseSteer.of(kart), clearance=clearance)

    def closing_limit(self, across: float) -> float:
        """The ego's highest sideways speed [m/s] toward a kart ``across`` [m] away (centre to centre): the speed
        from which turning away stops closing at the clearance (none inside it)."""
        return self.steer.closing_limit(abs(across) - self.clearance)

    def bounds(self, me: KartView, others: Iterable[KartView], track: Track) -> CourseBounds | None:
        """The course the ego may hold against the track's direction; None with nobody alongside."""
        low, high = -math.inf, math.inf
        for other in others:
            if other.index == me.index or other.finished:
                continue
            if abs(track.gap(me.progress, other.progress)) >= self.reach:
                continue
            across = other.lateral - me.lateral
            if abs(across) >= self.zone:
                continue
            angle = self.steer.course_toward(abs(across) - self.clearance, me.speed)
            if across > 0.0:  # on the left: the course may turn left by at most ``angle``
                high = min(high, angle)
            else:
                low = max(low, -angle)
        if low == -math.inf and high == math.inf:
            return None
        if low > high:  # a kart on each side: hold the track's direction
            return CourseBounds(0.0, 0.0)
        return CourseBounds(low, high)


@dataclass(frozen=True)
class LaneLimitShield:
    """Bound the ego's sideways motion toward lanes its spent lane changes no longer reach (see the module)."""

    steer: CourseSteer
    lane_offsets: np.ndarray = field(repr=False)  # (M, lanes) every centre-line sample's lane offsets (the referee's)
    lane_change_limit: int = 3  # L of eq. (11)
    hysteresis: float = RuleParams().lane_hysteresis  # [m] the referee's lane membership
    margin: float = 0.15  # [m] kept short of where the referee's lane membership changes

    @classmethod
    def of(cls, kart: KartParams, track: Track, lane_change_limit: int, margin: float = 0.15) -> LaneLimitShield:
        """The shield for ``kart`` on ``track`` under a limit of ``lane_change_limit`` changes per straight."""
        offsets = np.ascontiguousarray(track.sample_lane_offsets(), dtype=np.float64)
        return cls(CourseSteer.of(kart), offsets, lane_change_limit, margin=margin)

    def band(self, me: KartView, track: Track) -> tuple[float, float] | None:
        """The lateral offsets [m] (low, high) the kart may reach without an illegal change; None on a curve, before
        its lane is known, or with every lane within reach."""
        if me.lane_now <= 0 or not track.section_is_straight(me.checkpoints_passed):
            return None
        spare = max(self.lane_change_limit - me.lane_changes_now, 0)
        offsets = self.lane_offsets[track.sample_at(me.progress)]  # lane 1 leftmost: offsets fall with the lane id
        lanes = len(offsets)
        leftmost, rightmost = max(1, me.lane_now - spare), min(lanes, me.lane_now + spare)
        if leftmost == 1 and rightmost == lanes:
            return None
        slack = self.hysteresis - self.margin
        high = math.inf if leftmost == 1 else 0.5 * float(offsets[leftmost - 1] + offsets[leftmost - 2]) + slack
        low = -math.inf if rightmost == lanes else 0.5 * float(offsets[rightmost - 1] + offsets[rightmost]) - slack
        return low, high

    def bounds(self, me: KartView, track: Track) -> CourseBounds | None:
        """The course the ego may hold against the track's direction; None where :meth:`band` is."""
        band = self.band(me, track)
        if band is None:
            return None
        low, high = band
        return CourseBounds(
            -math.inf if low == -math.inf else -self._course_within(me.lateral - low, me.speed),
            math.inf if high == math.inf else self._course_within(high - me.lateral, me.speed),
        )

    def _course_within(self, room: float, speed: float) -> float:
        """The largest course angle [rad] toward an edge ``room`` [m] away across; past it (``room`` < 0), the
        course back that returns as fast as it may approach from as far inside (a course along the edge would
        leave the kart outside, drifting on its slip)."""
        if room >= 0.0:
            return self.steer.course_toward(room, speed)
        return -self.steer.course_toward(-room, speed)
