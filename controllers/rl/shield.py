"""Shields of the RL tracker: rules a learned policy's pedal is held to at race time (ours, not the paper's).

:class:`LineSpeedShield`: the RL tracker of a hierarchical agent never drives faster than the racing line's speed
profile allows, as the LQNG tracker never does. :class:`FollowingShield`: it never closes on a kart ahead in its
path faster than it could still brake to that kart's speed short of the rules' buffer.

Ours, not the paper's. The policies were trained on ovals and a hairpin circuit; on ``complex`` they enter its
hairpins (inside radius 1–5 m) too fast, run wide and lose 1–3 s each. The LQNG tracker
takes the offline racing line's speed profile as a ceiling (:class:`controllers.lq.tracker.LQNGTracker`); the
shield gives the RL tracker of ``mcts-rl`` and ``fixed-rl`` the same part of the high level: above the profile
plus a margin it brakes, with the policy's own pedal kept whenever that slows the kart more. Steering stays the
policy's. ``e2e`` has no planner and so, by default, no shield.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from controllers.base import Action
from controllers.racing_line import RacingLine, brake_sweep
from sim_core.kart import throttle_for_acceleration
from sim_core.observation import KartView
from sim_core.params import KartParams, RuleParams
from sim_core.track import Track


@dataclass(frozen=True)
class LineSpeedShield:
    """Brake toward the ceiling when over it (deceleration ``gain`` per m/s over, saturating at the kart's
    braking limit). The ceiling (:meth:`of`) is the racing line's speed profile plus a margin, with braking zones
    that begin earlier than the line's own: the kart's path is not the line's, so the distance it has left to
    brake is judged along the centre line at a fraction of its braking limit."""

    s: np.ndarray  # (M + 1,) [m] centre-line progress of the samples, the first repeated one lap on
    ceiling_speed: np.ndarray  # (M + 1,) [m/s]
    kart: np.ndarray  # the kart's packed parameters (sim_core.kart)
    gain: float = 10.0  # [1/s]

    @classmethod
    def of(
        cls, line: RacingLine, kart: KartParams, margin: float = 1.0, braking_use: float = 0.7, gain: float = 10.0
    ) -> LineSpeedShield:
        """The shield of ``line`` for ``kart``: the profile plus ``margin`` [m/s], and no faster than braking at
        ``braking_use`` of the kart's limit lets it reach that anywhere ahead (a backward pass, twice round the
        closed line)."""
        s_closed = line.closed_s
        ceiling = np.asarray(line.speed, dtype=np.float64) + margin
        ds = np.diff(s_closed)
        for _ in range(2):
            brake_sweep(ceiling, ds, braking_use * kart.braking)
        return cls(s_closed, np.append(ceiling, ceiling[0]), kart.as_array(), gain)

    def ceiling(self, progress: float) -> float:
        """Highest allowed speed [m/s] at ``progress`` [m] along the centre line."""
        return float(np.interp(progress % self.s[-1], self.s, self.ceiling_speed))

    def limit(self, action: Action, speed: float, progress: float) -> Action:
        """``action`` with its pedal lowered to a brake when ``speed`` is over the ceiling at ``progress``."""
        excess = speed - self.ceiling(progress)
        if excess <= 0.0:
            return action
        pedal = throttle_for_acceleration(self.kart, speed, -self.gain * excess)
        if pedal >= action.throttle:
            return action
        return Action(action.steer, float(pedal))


@dataclass(frozen=True)
class FollowingShield:
    """Keep off the kart ahead: brake whenever the ego closes on another kart in its path faster than it could
    still brake to that kart's speed before the gap falls to ``standoff``.

    The policies were trained against one opponent on ovals and run into the back of a kart braking ahead of
    them, or nose into one that moves across: 13 collisions at fault in 20 races of ``mcts-rl`` against
    ``fixed-rl`` on ``complex`` without this shield, 1 with it. A kart is in the
    ego's path when it is ahead along the centre line by less than ``reach`` and, now or ``lookahead`` seconds
    on at both karts' present sideways speeds, laterally closer than ``clearance``. The allowed speed is that
    kart's speed along the track plus ``sqrt(2 b (gap - standoff))`` (``b``: ``braking_use`` of the kart's
    braking limit), the speed from which braking at ``b`` meets it at the standoff (inside the standoff: that
    much under its speed, to open the gap again); over it, the pedal brakes at ``gain`` per m/s over
    (saturating at the kart's limit). Only ever a lower pedal; steering stays the policy's, so the ego may still
    pull out and pass."""

    kart: np.ndarray  # the kart's packed parameters (sim_core.kart)
    standoff: float  # [m] centre-to-centre gap along the track kept to a kart ahead in the path, not level with it
    standoff_behind: float  # [m] ... and to a kart directly ahead (lateral centre distance under a body width)
    clearance: float  # [m] lateral centre distance under which a kart ahead is in the path now
    # [m] ... and under which it is in the path ``lookahead`` seconds on (the extrapolation is already a worst
    # case, so only a small margin over the body width)
    clearance_then: float
    width: float  # [m] the body's width
    braking: float  # [m/s^2] deceleration the allowed speed assumes
    lookahead: float = 0.0  # [s] how far ahead the karts' sideways motion is extrapolated
    reach: float = 20.0  # [m] karts further ahead than this are ignored
    gain: float = 10.0  # [1/s]

    @classmethod
    def of(
        cls,
        kart: KartParams,
        rules: RuleParams | None = None,
        braking_use: float = 0.6,
        lookahead: float = 0.0,
    ) -> FollowingShield:
        """The shield for ``kart``: standoffs of a body length plus the rules' buffers (eqs. (8)-(9)
        gen_coll_avoid: s1 directly behind, s0 otherwise), a clearance of a body width plus 0.3 m now and plus
        0.1 m ``lookahead`` seconds on."""
        rules = rules or RuleParams()
        length = kart.body_length
        width = 2.0 * kart.body_radius
        return cls(
            kart.as_array(),
            length + rules.buffer_side,
            length + rules.buffer_behind,
            width + 0.3,
            width + 0.1,
            width,
            braking_use * kart.braking,
            lookahead,
        )

    def allowed_speed(self, me: KartView, others: Iterable[KartView], track: Track) -> float:
        """The highest speed [m/s] the ego may drive now (infinite when nobody is in its path)."""
        allowed = math.inf
        _, my_sideways = _track_velocity(me, track)
        for other in others:
            if other.index == me.index or other.finished:
                continue
            gap = track.gap(me.progress, other.progress)
            if not 0.0 < gap < self.reach:
                continue
            along, sideways = _track_velocity(other, track)
            lateral_now = other.lateral - me.lateral
            lateral_then = lateral_now + (sideways - my_sideways) * self.lookahead
            clear_now = abs(lateral_now) >= self.clearance
            if clear_now and abs(lateral_then) >= self.clearance_then and lateral_now * lateral_then > 0.0:
                continue
            standoff = self.standoff_behind if abs(lateral_now) < self.width else self.standoff
            # inside the standoff already: slower than the other kart, to open the gap again
            room = gap - standoff
            allowed = min(allowed, max(along, 0.0) + math.copysign(math.sqrt(2.0 * self.braking * abs(room)), room))
        return allowed

    def limit(self, action: Action, me: KartView, others: Iterable[KartView], track: Track) -> Action:
        """``action`` with its pedal lowered to a brake when the ego is over :meth:`allowed_speed`."""
        excess = me.speed - self.allowed_speed(me, others, track)
        if excess <= 0.0:
            return action
        pedal = throttle_for_acceleration(self.kart, me.speed, -self.gain * excess)
        if pedal >= action.throttle:
            return action
        return Action(action.steer, float(pedal))


def _track_velocity(kart: KartView, track: Track) -> tuple[float, float]:
    """The kart's velocity [m/s] along and across (left-positive) the track, from its heading against the centre
    line's there."""
    _, tangent = track.point_at(kart.progress)
    angle = kart.heading - math.atan2(float(tangent[1]), float(tangent[0]))
    return kart.speed * math.cos(angle), kart.speed * math.sin(angle)
