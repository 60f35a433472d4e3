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
from controllers.racing_line import RacingLine
from sim_core.kart import throttle_for_acceleration


@dataclass(frozen=True)
class LineSpeedShield:
    """Brake toward ``line`` speed profile plus ``margin`` when over it (deceleration ``gain`` per m/s over,
    saturating at the kart's braking limit)."""

    line: RacingLine
    kart: np.ndarray  # the kart's packed parameters (sim_core.kart)
    margin: float = 1.0  # [m/s] the policy's own line is not the racing line: a little slack
    gain: float = 3.0  # [1/s]

    def ceiling(self, progress: float) -> float:
        """Highest allowed speed [m/s] at ``progress`` [m] along the centre line."""
        return float(self.line.speed_at(progress)) + self.margin

    def limit(self, action: Action, speed: float, progress: float) -> Action:
        """``action`` with its pedal lowered to a brake when ``speed`` is over the ceiling at ``progress``."""
        excess = speed - self.ceiling(progress)
        if excess <= 0.0:
            return action
        pedal = throttle_for_acceleration(self.kart, speed, -self.gain * excess)
        if pedal >= action.throttle:
            return action
        return Action(action.steer, float(pedal))
