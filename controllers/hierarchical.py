"""Hierarchical drivers built from parts: a high-level planner (the MCTS tactical planner,
:mod:`controllers.tactical.high_level`, or the fixed racing line, :mod:`controllers.fixed_line`) re-planning at
~1 Hz and a tracker acting at 50 Hz (the LQNG tracker, :mod:`controllers.lq.tracker`).

The paper's stale-plan effect is kept: a plan is computed from the state at the moment it is requested and
only takes effect ``plan_latency`` seconds later (simulated time, so headless races stay deterministic; the
live server delivers plans when its worker finishes).
"""

from __future__ import annotations

from dataclasses import dataclass

from controllers.base import Action, HighLevelPlanner, RaceContext, Tracker
from controllers.plan import Plan
from sim_core.observation import Observation
from sim_core.params import SIM_HZ


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
