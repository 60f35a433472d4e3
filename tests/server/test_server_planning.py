"""The planner worker pool: plans come back from another process; a worker that dies or hangs is replaced and
its planners are rebuilt on their next request, without the caller being cancelled."""

from __future__ import annotations

import asyncio
import os
import signal
import time

import pytest

from controllers.base import RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.plan import Plan
from controllers.registry import REGISTRY
from server.planning import PlannerPool, PlannerSetup, PlannerUnavailableError
from sim_core.observation import Observation, observe
from sim_core.params import SimParams
from sim_core.track_io import get_track
from sim_core.world import World


class SleepyPlanner:
    """A planner that never finishes (in the worker process)."""

    rate_hz = 1.0

    def reset(self, context: RaceContext) -> None:
        """Nothing to prepare."""

    def plan(self, observation: Observation) -> Plan:
        """Sleeps."""
        time.sleep(60)
        raise AssertionError("unreachable")


def sleepy_controller() -> HierarchicalController:
    """A module-level factory: the worker process imports it by name."""
    return HierarchicalController("sleepy", SleepyPlanner(), LQNGTracker())  # type: ignore[arg-type]


def _worker_pids(pool: PlannerPool) -> list[int]:
    processes = [p for w in pool._workers for p in w.executor._processes.values()]  # type: ignore[attr-defined]
    return [p.pid for p in processes if p.pid is not None]


def _grid(ego: int) -> tuple[Observation, RaceContext]:
    """Kart ``ego``'s observation on the oval's grid (two karts) and its race context."""
    track = get_track("oval")
    params = SimParams()
    world = World(track, 1, 2, params, laps=1)
    return observe(world, 0)[ego], RaceContext(track, params.kart, ego, 2, world.lane_change_limit, 0)


def test_plans_survive_a_dead_and_a_hung_worker() -> None:
    observation, context = _grid(1)

    async def scenario() -> None:
        pool = PlannerPool(1)
        try:
            await pool.wait_warm()
            await pool.open("race/1", PlannerSetup(REGISTRY["fixed-lqng"].factory, context))
            plan = await pool.plan("race/1", observation)
            assert plan.ego == 1 and len(plan.ego_waypoints) == 8

            for pid in _worker_pids(pool):
                os.kill(pid, signal.SIGKILL)
            with pytest.raises(PlannerUnavailableError):
                await pool.plan("race/1", observation)
            assert (await pool.plan("race/1", observation)).ego_waypoints == plan.ego_waypoints  # rebuilt

            await pool.open("race/2", PlannerSetup(sleepy_controller, context))
            hung = asyncio.get_running_loop().create_task(pool.plan("race/2", observation))
            await asyncio.sleep(0.5)
            assert not pool.replace_if_stuck("race/2", 5.0)  # busy, but not for long
            assert pool.replace_if_stuck("race/2", 0.2)
            with pytest.raises(PlannerUnavailableError):
                await hung
            assert (await pool.plan("race/1", observation)).ego_waypoints == plan.ego_waypoints
            assert pool.restarts == 2
        finally:
            await asyncio.to_thread(pool.shutdown)

    asyncio.run(scenario())


class BudgetEchoPlanner:
    """A planner that can cut its plans short (``TimeBoundedPlanner``): its plan reports the budget it was given
    as its ``seconds``."""

    rate_hz = 1.0

    def __init__(self) -> None:
        self.plan_budget_s: float | None = None

    def reset(self, context: RaceContext) -> None:
        """Nothing to prepare."""

    def plan(self, observation: Observation) -> Plan:
        """An empty plan carrying the budget."""
        return Plan(observation.ego, 0, {}, 0, 0, -1.0 if self.plan_budget_s is None else self.plan_budget_s)


def budget_echo_controller() -> HierarchicalController:
    """A module-level factory: the worker process imports it by name."""
    return HierarchicalController("budget-echo", BudgetEchoPlanner(), LQNGTracker())  # type: ignore[arg-type]


def test_a_time_bounded_planner_gets_the_live_budget_in_its_worker() -> None:
    """The setup's wall-clock budget reaches a planner that can cut its plans short, in the worker process;
    planners without the capability (fixed-lqng's) are built as before."""
    observation, context = _grid(0)

    async def scenario() -> None:
        pool = PlannerPool(1)
        try:
            await pool.open("race/1", PlannerSetup(budget_echo_controller, context, 0.25))
            assert (await pool.plan("race/1", observation)).seconds == 0.25
            await pool.open("race/2", PlannerSetup(budget_echo_controller, context))
            assert (await pool.plan("race/2", observation)).seconds == -1.0  # no budget: headless
            await pool.open("race/3", PlannerSetup(REGISTRY["fixed-lqng"].factory, context, 0.25))
            assert len((await pool.plan("race/3", observation)).ego_waypoints) == 8
        finally:
            await asyncio.to_thread(pool.shutdown)

    asyncio.run(scenario())
