"""The line-speed shield: the RL tracker of a hierarchical agent never drives faster than the racing line's speed
profile allows, as the LQNG tracker never does.

Ours, not the paper's. The policies were trained on ovals and a hairpin circuit; on ``complex`` they enter its
hairpins (inside radius 1–5 m) too fast, run wide and lose 1–3 s each (results/rl/README.md). The LQNG tracker
takes the offline racing line's speed profile as a ceiling (:class:`controllers.lq.tracker.LQNGTracker`); the
shield gives the RL tracker of ``mcts-rl`` and ``fixed-rl`` the same part of the high level: above the profile
plus a margin it brakes, with the policy's own pedal kept whenever that slows the kart more. Steering stays the
policy's. ``e2e`` has no planner and so, by default, no shield.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from controllers.base import Action
from controllers.racing_line import RacingLine, brake_sweep
from sim_core.kart import throttle_for_acceleration
from sim_core.params import KartParams


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
