"""Stall recovery: get a stalled kart going again (drive off along the wall, or back off it), then hand back to
the policy; and never let the policy reverse on its own.

Ours, not the paper's. Trained on the ovals and a hairpin circuit, the RL agents sometimes stop against the
outside wall at the exit of a hairpin they have never seen and coast there, or reverse away from the track for
seconds (measured on ``complex``). A real racing stack has such a manoeuvre; this one is
deliberately simple: an action filter (:class:`controllers.rl.filters.RecoverFromStall`) that every RL agent
composes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from controllers.base import Action


@dataclass
class StallRecovery:
    """After ``stall_time`` below ``stall_speed``, a manoeuvre of ``reverse_time``: a kart pointing within
    ``drive_off_heading`` of the track's direction drives off at full throttle steering toward it; any other
    reverses with the steering that turns the nose toward the track's direction (reversing, the nose turns
    against the steer). Between manoeuvres, :meth:`forward_only` keeps the policy from reversing."""

    stall_speed: float = 0.5  # [m/s]
    stall_time: float = 0.5  # [s] stalled before the manoeuvre
    standstill_speed: float = 0.3  # [m/s] below this a held brake would reverse: the policy's brake is released
    reverse_time: float = 1.0  # [s] how long a manoeuvre lasts
    drive_off_heading: float = math.radians(60.0)  # [rad] stalled this close to the track's direction: drive off
    drive_off_steer_gain: float = 2.0  # [1/rad]
    stalled_since: float | None = None
    pedal: float = -1.0
    reversing_until: float = -math.inf
    steer: float = 0.0
    manoeuvres: int = 0

    def reset(self) -> None:
        """A new race."""
        self.stalled_since, self.reversing_until, self.manoeuvres = None, -math.inf, 0
        self.steer, self.pedal = 0.0, -1.0

    def forward_only(self, action: Action, speed: float) -> Action:
        """``action`` with a brake held at a standstill or while rolling backwards released: only the recovery
        manoeuvre reverses. A policy that reverses on its own backs away from the track for seconds (measured:
        30 m back from a hairpin exit on ``complex``)."""
        if action.throttle < 0.0 and speed <= self.standstill_speed:
            return Action(action.steer, 0.0)
        return action

    def override(self, time: float, speed: float, heading_error: float) -> Action | None:
        """The recovery's action at race ``time`` [s] for a kart at ``speed`` [m/s] whose heading is
        ``heading_error`` [rad] to the right of the track's direction (positive: the track turns left of the
        nose), or None to let the policy drive."""
        if time < self.reversing_until:
            return Action(self.steer, self.pedal)
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
        self.manoeuvres += 1
        if abs(heading_error) < self.drive_off_heading:
            # pointing down the track (stopped beside a wall, not into it): drive off, steering toward the
            # track's direction
            self.steer = min(max(self.drive_off_steer_gain * heading_error, -1.0), 1.0)
            self.pedal = 1.0
        else:
            self.steer = -1.0 if heading_error > 0.0 else 1.0
            self.pedal = -1.0
        return Action(self.steer, self.pedal)
