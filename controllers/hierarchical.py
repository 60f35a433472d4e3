"""Hierarchical drivers built from parts: a high-level planner (MCTS tactical planner, or the fixed racing
line) re-planning at ~1 Hz and a tracker acting at 50 Hz.

The paper's stale-plan effect is kept: a plan is computed from the state at the moment it is requested and
only takes effect ``plan_latency`` seconds later (simulated time, so headless races stay deterministic; the
live server delivers plans when its worker finishes).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from controllers.base import Action, HighLevelPlanner, RaceContext, Tracker
from controllers.plan import Plan, Waypoint
from controllers.racing_line import RacingLine, optimise_racing_line
from controllers.tactical.game import GameParams
from controllers.tactical.planner import PlayerState, TacticalPlanner
from sim_core.observation import Observation
from sim_core.params import SIM_HZ
from sim_core.rules import lane_change_update
from sim_core.track import Track

INTERACTION_WINDOW = 1.0  # [s] another kart predicted at a checkpoint this close in time makes it tactical


def _lanes_legal(track: Track, lane: int, count: int, waypoints: list[Waypoint], limit: int) -> bool:
    """Whether driving through ``waypoints`` from ``lane`` (lane-change counter ``count``) breaks no rule."""
    for w in waypoints:
        c = w.checkpoint
        count, illegal = lane_change_update(
            count, lane, w.lane, track.section_is_straight(c - 1), track.section_is_straight(c), limit
        )
        if illegal:
            return False
        lane = w.lane
    return True


class MCTSPlanner:
    """The paper's tactical planner as a high-level part: MCTS over the discrete game.

    With ``racing_line`` on, the search decides the lanes only where karts interact: an ego waypoint with no
    other kart predicted at that checkpoint within ``INTERACTION_WINDOW`` takes the offline racing line's lane
    when the lane-change rule allows it. The discrete game's lane-radius time model cannot tell apart lane
    choices worth a few hundredths of a second each, and 2,000 iterations cannot either; over a lap they add
    up to the gap between a tactical planner and a line follower (measured in the closing note of issue 4).
    """

    def __init__(
        self, iterations: int = 2000, rate_hz: float = 1.0, params: GameParams | None = None, racing_line: bool = True
    ) -> None:
        self.iterations = iterations
        self.rate_hz = rate_hz
        self.params = params or GameParams()
        self.racing_line = racing_line
        self._planner: TacticalPlanner | None = None
        self._context: RaceContext | None = None
        self._line_lanes: tuple[int, ...] = ()

    def reset(self, context: RaceContext) -> None:
        """Build the game tables for this track and kart (and the racing line's lanes)."""
        self._context = context
        if self.racing_line:
            self._line_lanes = optimise_racing_line(context.track, context.kart).checkpoint_lanes
        self._planner = TacticalPlanner(
            context.track,
            context.kart,
            self.params,
            iterations=self.iterations,
            seed=context.seed,
            lane_limit=context.lane_change_limit,
        )

    def plan(self, observation: Observation) -> Plan:
        """Search from the karts' states at their last checkpoint crossings."""
        assert self._planner is not None, "reset() first"
        players = [
            PlayerState(
                kart=k.index,
                checkpoint=max(k.checkpoints_passed, 0),
                lane=k.lane,
                speed=k.crossing_speed,
                time=k.crossing_time,
                wear=k.crossing_wear,
                lane_changes=k.lane_changes,
            )
            for k in observation.karts
            if not k.finished or k.index == observation.ego
        ]
        plan = self._planner.plan(players, observation.ego)
        return self._prefer_racing_line(plan, observation) if self.racing_line else plan

    def _prefer_racing_line(self, plan: Plan, observation: Observation) -> Plan:
        """``plan`` with every non-tactical ego waypoint moved to the racing line's lane where that is legal."""
        assert self._context is not None
        track = self._context.track
        limit = self._context.lane_change_limit
        opponents = [w for ws in plan.opponent_waypoints().values() for w in ws]
        me = observation.me
        waypoints = list(plan.ego_waypoints)
        lane, count = me.lane, me.lane_changes
        for i, w in enumerate(waypoints):
            line_lane = self._line_lanes[w.checkpoint % track.n_checkpoints]
            tactical = any(
                o.checkpoint == w.checkpoint and abs(o.time - w.time) < INTERACTION_WINDOW for o in opponents
            )
            if line_lane != w.lane and not tactical:
                point = track.lane_point(w.checkpoint, line_lane)
                snapped = replace(w, lane=line_lane, position=(float(point[0]), float(point[1])))
                if _lanes_legal(track, lane, count, [snapped, *waypoints[i + 1 :]], limit):
                    waypoints[i] = snapped
            c = waypoints[i].checkpoint
            count, _ = lane_change_update(
                count, lane, waypoints[i].lane, track.section_is_straight(c - 1), track.section_is_straight(c), limit
            )
            lane = waypoints[i].lane
        return replace(plan, waypoints={**plan.waypoints, plan.ego: tuple(waypoints)})


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


@dataclass
class _PendingPlan:
    plan: Plan
    ready_at: float  # [s] race time


class HierarchicalController:
    """A planner part and a tracker part composed into one driver (``mcts-lqng``, ``fixed-lqng``, ...)."""

    def __init__(
        self, name: str, planner: HighLevelPlanner, tracker: Tracker, plan_latency: float = 0.1, rate_hz: float = SIM_HZ
    ) -> None:
        self.name = name
        self.planner = planner
        self.tracker = tracker
        self.plan_latency = plan_latency
        self.rate_hz = rate_hz
        self.active_plan: Plan | None = None
        self._pending: _PendingPlan | None = None
        self._next_request = 0.0
        self.plans_applied = 0

    def reset(self, context: RaceContext) -> None:
        """Reset both parts and forget plans."""
        self.planner.reset(context)
        self.tracker.reset(context)
        self.active_plan = None
        self._pending = None
        self._next_request = 0.0
        self.plans_applied = 0

    def wants_plan(self, time: float) -> bool:
        """Whether a re-plan is due at race time ``time`` (the planner's rate)."""
        return time >= self._next_request - 1e-9

    def request_plan(self, observation: Observation) -> Plan:
        """Plan from ``observation`` now (synchronously) and schedule it to apply after the latency."""
        self._next_request = observation.time + 1.0 / self.planner.rate_hz
        plan = self.planner.plan(observation)
        self._pending = _PendingPlan(plan, observation.time + self.plan_latency)
        return plan

    def mark_plan_requested(self, time: float) -> None:
        """Record that a plan was requested at race time ``time`` elsewhere (the live server's planner worker)."""
        self._next_request = time + 1.0 / self.planner.rate_hz

    def track(self, observation: Observation) -> Action:
        """The tracker's inputs for the active plan, without planning (live sessions plan in a worker)."""
        return self.tracker.act(observation, self.active_plan)

    def deliver(self, plan: Plan) -> None:
        """Make ``plan`` the active plan (the live server calls this when its worker finishes)."""
        self.active_plan = plan
        self.plans_applied += 1

    def act(self, observation: Observation) -> Action:
        """Re-plan when due, apply plans whose latency has passed, and track the active plan."""
        if self.wants_plan(observation.time):
            self.request_plan(observation)
        if self._pending is not None and observation.time >= self._pending.ready_at - 1e-9:
            self.deliver(self._pending.plan)
            self._pending = None
        return self.tracker.act(observation, self.active_plan)
