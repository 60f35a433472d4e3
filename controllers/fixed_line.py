"""The baselines' high-level part (``fixed-lqng``, the paper's Fixed-* agents): the offline racing line's lane
and speed at each coming checkpoint, re-read at the planner's rate. It *replays* a line computed once per
race and predicts no other kart; :class:`~controllers.tactical.high_level.MCTSPlanner` *searches* the racing
game against them.
"""

from __future__ import annotations

import numpy as np

from controllers.base import RaceContext
from controllers.plan import Plan, Waypoint
from controllers.racing_line import RacingLine, optimise_racing_line
from sim_core.observation import Observation


class FixedLinePlanner:
    """The baselines' high level: the offline racing line's lane and speed at each coming checkpoint."""

    def __init__(self, horizon: int = 8, rate_hz: float = 1.0, margin: float = 1.0) -> None:
        self.horizon = horizon
        self.rate_hz = rate_hz
        self.margin = margin
        self._line: RacingLine | None = None
        self._context: RaceContext | None = None

    def reset(self, context: RaceContext) -> None:
        """Optimise the racing line for this track and kart (tens of milliseconds)."""
        self._context = context
        self._line = optimise_racing_line(context.track, context.kart, margin=self.margin)

    @property
    def line(self) -> RacingLine:
        """The racing line in use."""
        assert self._line is not None, "reset() first"
        return self._line

    def plan(self, observation: Observation) -> Plan:
        """Waypoints on the racing line for the next ``horizon`` checkpoints."""
        assert self._context is not None and self._line is not None, "reset() first"
        track = self._context.track
        line = self._line
        first = max(observation.me.checkpoints_passed, 0) + 1
        waypoints = []
        for checkpoint in range(first, first + self.horizon):
            c = checkpoint % track.n_checkpoints
            lane = line.checkpoint_lanes[c]
            point = track.lane_point(c, lane)
            speed = float(np.interp(track.checkpoint_s[c], line.s, line.speed, period=track.length))
            waypoints.append(Waypoint(checkpoint, lane, (float(point[0]), float(point[1])), speed, 0.0))
        return Plan(observation.ego, first - 1, {observation.ego: tuple(waypoints)}, 0, 0, 0.0)
