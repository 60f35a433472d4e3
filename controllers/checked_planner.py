"""A tactical planner whose plans pass a :class:`~controllers.rollout_check.RolloutCheck` before they are sent (a
part for experiments: no registered agent uses it, see the rollout check's module note)."""

from __future__ import annotations

import time
from functools import partial

from controllers.base import RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.plan import Plan
from controllers.rollout_check import RolloutCheck, RolloutCheckSettings, TrackerFactory
from controllers.tactical.high_level import MCTSPlanner
from sim_core.observation import Observation


class CheckedPlanner:
    """An :class:`MCTSPlanner` whose plans pass a :class:`RolloutCheck`; the planner then holds the checked lanes as
    its commitment."""

    def __init__(self, inner: MCTSPlanner, check: RolloutCheck) -> None:
        self.inner = inner
        self.check = check
        self.rate_hz = inner.rate_hz
        # a live host's wall-clock budget per plan (:class:`~controllers.base.TimeBoundedPlanner`): once spent, the
        # check races no further branch of candidates. None (headless): every plan whole, deterministic
        self.plan_budget_s: float | None = None

    def reset(self, context: RaceContext) -> None:
        """Reset the search and the check."""
        self.inner.reset(context)
        self.check.reset(context)

    def plan(self, observation: Observation) -> Plan:
        """The search's plan, checked (within ``plan_budget_s`` of wall-clock time when set, plus one branch)."""
        budget = self.plan_budget_s
        self.check.deadline = None if budget is None else time.perf_counter() + budget
        self.check.lead_s = self.check.settings.lead_s if budget is None else budget
        plan = self.check.check(observation, self.inner.plan(observation), self.inner.line_lanes, self.inner.lane_limit)
        self.inner.commit(plan)
        return plan


def with_rollout_check(
    driver: HierarchicalController, settings: RolloutCheckSettings, rival_tracker: TrackerFactory
) -> HierarchicalController:
    """``driver`` (an MCTS planner over an LQNG tracker) with its plans checked: the ego's rollouts drive a copy of
    its own tracker, the kart ahead ``rival_tracker``'s."""
    planner, tracker = driver.planner, driver.tracker
    assert isinstance(planner, MCTSPlanner) and isinstance(tracker, LQNGTracker)
    ego = partial(LQNGTracker, tracker.params, tracker.rules)
    driver.planner = CheckedPlanner(planner, RolloutCheck(settings, ego, rival_tracker))
    return driver
