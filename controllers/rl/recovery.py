"""Stall recovery: back a stalled kart off the wall it has stopped against, then hand back to the policy.

Ours, not the paper's. Trained on the ovals and a hairpin circuit, the RL agents sometimes stop nose to the
outside wall at the exit of a hairpin they have never seen and coast there for the rest of the race (measured
on ``complex``: results/rl/README.md). A real racing stack has such a manoeuvre; this one is deliberately
simple and is a public parameter of every RL agent (``stall_recovery``), so a series can be run with it off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from controllers.base import Action


@dataclass
class StallRecovery:
    """After ``stall_time`` below ``stall_speed``, reverse for ``reverse_time`` with the steering that turns the
    nose toward the track's direction (reversing, the nose turns against the steer)."""

    stall_speed: float = 0.5  # [m/s]
    stall_time: float = 1.0  # [s] stalled before backing off
    reverse_time: float = 1.0  # [s]
    stalled_since: float | None = None
    reversing_until: float = -math.inf
    steer: float = 0.0
    manoeuvres: int = 0

    def reset(self) -> None:
        """A new race."""
        self.stalled_since, self.reversing_until, self.steer, self.manoeuvres = None, -math.inf, 0.0, 0

    def override(self, time: float, speed: float, heading_error: float) -> Action | None:
        """The recovery's action at race ``time`` [s] for a kart at ``speed`` [m/s] whose heading is
        ``heading_error`` [rad] to the right of the track's direction (positive: the track turns left of the
        nose), or None to let the policy drive."""
        if time < self.reversing_until:
            return Action(self.steer, -1.0)
        if abs(speed) >= self.stall_speed:
            self.stalled_since = None
            return None
        if self.stalled_since is None:
            self.stalled_since = time
            return None
        if time - self.stalled_since < self.stall_time:
            return None
        self.stalled_since = None
        self.reversing_until = time + self.reverse_time
        self.steer = -1.0 if heading_error > 0.0 else 1.0
        self.manoeuvres += 1
        return Action(self.steer, -1.0)
