"""The RL tracker's action filters (ours, not the paper's): its shields and its stall recovery, each an
:class:`~controllers.base.ActionFilter` with its settings, composed per agent in :mod:`controllers.rl.agents`.

* :class:`LineSpeedCeiling` — never faster than the racing line's speed profile plus a margin
  (:class:`~controllers.rl.shield.LineSpeedShield`);
* :class:`KeepDistance` — never closing on a kart ahead in the path faster than braking could still meet it
  short of the rules' buffer (:class:`~controllers.rl.shield.FollowingShield`);
* :class:`GiveRoomAlongside` — never moving sideways into a kart alongside faster than the referee lets a kart
  alongside move (:class:`~controllers.rl.sideways.SideRoomShield`);
* :class:`KeepToLaneLimit` — never crossing into a lane the lane-change rule no longer allows on this straight
  (:class:`~controllers.rl.sideways.LaneLimitShield`);
* :class:`RecoverFromStall` — a stalled kart drives off (or backs off a wall) for 1 s, and the policy never
  reverses on its own (:class:`~controllers.rl.recovery.StallRecovery`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from controllers.base import Action, RaceContext
from controllers.racing_line import optimise_racing_line
from controllers.rl.course import CourseBounds, CourseSteer
from controllers.rl.recovery import StallRecovery
from controllers.rl.shield import FollowingShield, LineSpeedShield
from controllers.rl.sideways import LaneLimitShield, SideRoomShield
from sim_core.observation import Observation
from sim_core.track import Track


@dataclass
class LineSpeedCeiling:
    """Brake when over the racing line's speed profile (the line ``line_margin`` m inside the walls, as the
    planner's) by more than ``margin`` [m/s]; the policy's own pedal stands whenever it slows the kart more."""

    margin: float = 1.0  # [m/s]
    line_margin: float = 1.0  # [m]
    _shield: LineSpeedShield | None = field(default=None, init=False, repr=False)

    def reset(self, context: RaceContext) -> None:
        """The ceiling of this race's track and kart."""
        line = optimise_racing_line(context.track, context.kart, margin=self.line_margin)
        self._shield = LineSpeedShield.of(line, context.kart, self.margin)

    def apply(self, action: Action, observation: Observation) -> Action:
        """``action`` with a brake when over the ceiling."""
        assert self._shield is not None, "reset() first"
        me = observation.me
        return self._shield.limit(action, me.speed, me.progress)

    @property
    def took_over(self) -> bool:
        """Never: it only lowers the policy's pedal."""
        return False


@dataclass
class KeepDistance:
    """Brake rather than close on a kart ahead in the path faster than it could stop short of the rules' buffer,
    judging the path ``lookahead`` [s] ahead at both karts' sideways speeds."""

    lookahead: float = 0.8  # [s]
    _shield: FollowingShield | None = field(default=None, init=False, repr=False)
    _track: Track | None = field(default=None, init=False, repr=False)

    def reset(self, context: RaceContext) -> None:
        """The shield of this race's kart."""
        self._shield = FollowingShield.of(context.kart, lookahead=self.lookahead)
        self._track = context.track

    def apply(self, action: Action, observation: Observation) -> Action:
        """``action`` with a brake when closing too fast."""
        assert self._shield is not None and self._track is not None, "reset() first"
        return self._shield.limit(action, observation.me, observation.karts, self._track)

    @property
    def took_over(self) -> bool:
        """Never: it only lowers the policy's pedal."""
        return False


class _CourseFilter:
    """What the sideways filters share: the kart's course (heading plus slip, the direction it travels, which the
    referee judges) measured from its displacement since the previous decision, and the steer that keeps it within
    the shield's bounds (:class:`~controllers.rl.course.CourseSteer`)."""

    _track: Track | None
    _last: tuple[float, float] | None  # the last decision's x, y

    def _bounds(self, observation: Observation) -> CourseBounds | None:
        raise NotImplementedError

    def _steer(self) -> CourseSteer:
        raise NotImplementedError

    def apply(self, action: Action, observation: Observation) -> Action:
        """``action`` with its steer changed where the course it leads to leaves the shield's bounds."""
        assert self._track is not None, "reset() first"
        me = observation.me
        course = me.heading
        if self._last is not None:
            dx, dy = me.x - self._last[0], me.y - self._last[1]
            if dx * dx + dy * dy > 1e-4:  # moved a centimetre: its direction is the course (heading + slip)
                course = math.atan2(dy, dx)
        self._last = (me.x, me.y)
        if me.speed < 1.0:
            return action
        bounds = self._bounds(observation)
        return action if bounds is None else self._steer().limit(action, me, course, bounds, self._track)

    @property
    def took_over(self) -> bool:
        """Never: the policy keeps its pedal, and its steer where the course stays within bounds."""
        return False


@dataclass
class GiveRoomAlongside(_CourseFilter):
    """Steer no further toward a kart alongside than closes the gap across to ``clearance`` [m] (centre to
    centre; :class:`~controllers.rl.sideways.SideRoomShield`)."""

    clearance: float = 1.1  # [m]
    _shield: SideRoomShield | None = field(default=None, init=False, repr=False)
    _track: Track | None = field(default=None, init=False, repr=False)
    _last: tuple[float, float] | None = field(default=None, init=False, repr=False)

    def reset(self, context: RaceContext) -> None:
        """The shield of this race's kart."""
        self._shield = SideRoomShield.of(context.kart, clearance=self.clearance)
        self._track = context.track
        self._last = None

    def _bounds(self, observation: Observation) -> CourseBounds | None:
        assert self._shield is not None and self._track is not None, "reset() first"
        return self._shield.bounds(observation.me, observation.karts, self._track)

    def _steer(self) -> CourseSteer:
        assert self._shield is not None, "reset() first"
        return self._shield.steer


@dataclass
class KeepToLaneLimit(_CourseFilter):
    """On a straight whose lane changes are spent, steer no further toward a lane the rule no longer allows than
    stops ``margin`` [m] short of where the referee would count the change
    (:class:`~controllers.rl.sideways.LaneLimitShield`)."""

    margin: float = 0.15  # [m]
    _shield: LaneLimitShield | None = field(default=None, init=False, repr=False)
    _track: Track | None = field(default=None, init=False, repr=False)
    _last: tuple[float, float] | None = field(default=None, init=False, repr=False)

    def reset(self, context: RaceContext) -> None:
        """The shield of this race's kart, track and lane-change limit."""
        self._shield = LaneLimitShield.of(context.kart, context.track, context.lane_change_limit, self.margin)
        self._track = context.track
        self._last = None

    def _bounds(self, observation: Observation) -> CourseBounds | None:
        assert self._shield is not None and self._track is not None, "reset() first"
        return self._shield.bounds(observation.me, self._track)

    def _steer(self) -> CourseSteer:
        assert self._shield is not None, "reset() first"
        return self._shield.steer


@dataclass
class RecoverFromStall:
    """After 0.5 s stalled, drive off (or back off a wall) for 1 s; between manoeuvres the policy never reverses."""

    recovery: StallRecovery = field(default_factory=StallRecovery)
    _track: Track | None = field(default=None, init=False, repr=False)
    _took_over: bool = field(default=False, init=False, repr=False)

    def reset(self, context: RaceContext) -> None:
        """A new race."""
        self.recovery.reset()
        self._track = context.track
        self._took_over = False

    def apply(self, action: Action, observation: Observation) -> Action:
        """The manoeuvre's action while one runs; ``action`` with a reversing brake released otherwise."""
        assert self._track is not None, "reset() first"
        me = observation.me
        _, tangent = self._track.point_at(me.progress)
        error = math.remainder(math.atan2(tangent[1], tangent[0]) - me.heading, math.tau)
        action = self.recovery.forward_only(action, me.speed)
        override = self.recovery.override(observation.time, me.speed, error)
        self._took_over = override is not None
        return action if override is None else override

    @property
    def took_over(self) -> bool:
        """Whether the last action was the manoeuvre's."""
        return self._took_over
