"""A test driver that holds one command: a user's controller at its simplest (no parameters, no batch path)."""

from __future__ import annotations

from controllers.base import Action, RaceContext
from sim_core.observation import Observation


class ConstantDriver:
    """Holds ``steer`` and ``throttle`` (class attributes: a subclass sets its own, and its name and rate)."""

    name = "test-constant"
    rate_hz = 50.0
    steer = 0.0
    throttle = 0.6

    def reset(self, context: RaceContext) -> None:
        """Nothing to prepare."""

    def act(self, observation: Observation) -> Action:
        """The same command every time."""
        return Action(self.steer, self.throttle)
