"""High-level planning off the tick path: planner worker processes shared by every race.

Each worker process keeps its own planner per ``(race, kart)`` key, built from the registered controller's
factory and reset with the race's context once; afterwards a request carries only the observation (about
1 KB) and the answer is the :class:`~controllers.plan.Plan` (about 1 KB). A key always goes to
the same worker, so the MCTS tree reuse across re-plans works. Workers start with the ``spawn`` method and
warm up by planning once, so numba's compiled kernels (``cache=True``) are loaded before the first race.

A worker that dies or hangs is replaced; the planners it held are rebuilt on their next request.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import multiprocessing
import time
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from arena.lifeline import die_with_parent
from controllers.base import HighLevelPlanner, PlanningDriver, TimeBoundedPlanner
from controllers.plan import Plan
from server.controller_params import build_controller
from server.host_messages import ClosePlanners, OpenPlanner, PlannerSetup, RequestPlan, ToPlanner, WarmPlanner
from server.loop import make_ordinary
from server.warmup import warm_planner
from sim_core.observation import Observation

log = logging.getLogger(__name__)


class PlannerUnavailableError(RuntimeError):
    """The worker holding a planner died or was replaced before answering (the next request rebuilds it)."""


class PlannerMissingError(RuntimeError):
    """The worker holds no planner for this key (it was restarted): send the setup again."""


# ----------------------------------------------------------------------------------------- worker process side
_planners: dict[str, HighLevelPlanner] = {}


def _build(key: str, setup: PlannerSetup) -> HighLevelPlanner:
    driver = build_controller(setup.factory)
    if not isinstance(driver, PlanningDriver):
        raise TypeError(f"{driver.name} does not plan off the tick: no planner to build")
    planner = driver.planner
    if isinstance(planner, TimeBoundedPlanner):
        planner.plan_budget_s = setup.plan_budget_s
    planner.reset(setup.context)
    _planners[key] = planner
    return planner


def _plan(key: str, observation: Observation, setup: PlannerSetup | None) -> Plan:
    planner = _planners.get(key)
    if planner is None:
        if setup is None:
            raise PlannerMissingError(key)
        planner = _build(key, setup)
    return planner.plan(observation)


def _worker_handle(message: ToPlanner) -> float | Plan | None:
    """Do what ``message`` asks in this worker process; returns its answer (see :mod:`server.host_messages`)."""
    match message:
        case RequestPlan(key, observation, setup):
            return _plan(key, observation, setup)
        case OpenPlanner(key, setup):
            start = time.perf_counter()
            _build(key, setup)
            return time.perf_counter() - start
        case ClosePlanners(keys):
            for key in keys:
                _planners.pop(key, None)
            return None
        case WarmPlanner():
            return warm_planner()


def _start_worker() -> None:
    """A worker's first act: die with the server (no orphan after a crash), at ordinary scheduling priority."""
    die_with_parent()
    make_ordinary()


# ----------------------------------------------------------------------------------------- server side
class _Worker:
    """One single-process executor and the keys whose planners it holds."""

    def __init__(self, slot: int) -> None:
        self.slot = slot
        self.executor = ProcessPoolExecutor(
            1, mp_context=multiprocessing.get_context("spawn"), initializer=_start_worker
        )
        self.opened: set[str] = set()  # keys built in the current process
        self.keys: set[str] = set()  # keys routed here
        self.in_flight = 0  # calls submitted and not answered
        self.last_progress = time.monotonic()  # the last answer, or the start of the current busy spell
        self.warm: Future[Any] = self.executor.submit(_worker_handle, WarmPlanner())


class PlannerPool:
    """``n_workers`` planner processes; a key is pinned to the least-loaded worker when it is opened."""

    def __init__(self, n_workers: int = 1) -> None:
        if n_workers < 1:
            raise ValueError(f"n_workers must be >= 1, got {n_workers}")
        self._workers = [_Worker(i) for i in range(n_workers)]
        self._home: dict[str, _Worker] = {}
        self._setups: dict[str, PlannerSetup] = {}
        self.restarts = 0

    async def wait_warm(self) -> list[float]:
        """Wait for every worker's warm-up plan; returns their seconds."""
        return [float(await asyncio.wrap_future(w.warm)) for w in self._workers]

    async def open(self, key: str, setup: PlannerSetup) -> float:
        """Build the planner of ``key`` in its worker; returns the seconds it took there."""
        worker = min(self._workers, key=lambda w: len(w.keys))
        self._home[key] = worker
        self._setups[key] = setup
        worker.keys.add(key)
        seconds = await self._call(worker, OpenPlanner(key, setup))
        worker.opened.add(key)
        assert isinstance(seconds, float)
        return seconds

    async def plan(self, key: str, observation: Observation) -> Plan:
        """A plan for ``key`` from ``observation`` (raises what the planner raised, or
        :class:`PlannerUnavailableError`)."""
        worker = self._home[key]
        setup = None if key in worker.opened else self._setups[key]
        plan = await self._call(worker, RequestPlan(key, observation, setup))
        worker.opened.add(key)
        assert isinstance(plan, Plan)
        return plan

    def close(self, keys: tuple[str, ...]) -> None:
        """Forget ``keys`` here and (without waiting) in their workers."""
        for worker in self._workers:
            mine = tuple(k for k in keys if k in worker.keys)
            if mine:
                worker.keys.difference_update(mine)
                worker.opened.difference_update(mine)
                # a worker being replaced forgets everything anyway
                with contextlib.suppress(BrokenProcessPool, RuntimeError):
                    worker.executor.submit(_worker_handle, ClosePlanners(mine))
        for key in keys:
            self._home.pop(key, None)
            self._setups.pop(key, None)

    def replace_if_stuck(self, key: str, timeout: float) -> bool:
        """Kill and replace the worker of ``key`` if it has been busy for ``timeout`` seconds without answering
        anything (a hung planner; a merely slow one is left alone). Its other planners are rebuilt."""
        worker = self._home.get(key)
        if worker is None or worker.in_flight == 0 or time.monotonic() - worker.last_progress <= timeout:
            return False
        self._replace(worker, kill=True)
        return True

    async def _call(self, worker: _Worker, message: ToPlanner) -> float | Plan | None:
        if worker.in_flight == 0:
            worker.last_progress = time.monotonic()
        try:
            future = worker.executor.submit(_worker_handle, message)
        except (BrokenProcessPool, RuntimeError) as exc:  # died, or shut down by a replacement
            self._replace_if_current(worker)
            raise PlannerUnavailableError(str(exc)) from None
        worker.in_flight += 1
        try:
            answer: float | Plan | None = await asyncio.wrap_future(future)
            return answer
        except BrokenProcessPool as exc:
            self._replace_if_current(worker)
            raise PlannerUnavailableError(str(exc)) from None
        except asyncio.CancelledError:
            task = asyncio.current_task()
            if future.cancelled() and (task is None or not task.cancelling()):
                # the call was dropped with its worker, not the caller cancelled
                raise PlannerUnavailableError("the planner worker was replaced") from None
            raise
        finally:
            worker.in_flight -= 1
            worker.last_progress = time.monotonic()

    def _replace_if_current(self, worker: _Worker) -> None:
        if self._workers[worker.slot] is worker:
            self._replace(worker, kill=False)

    def _replace(self, worker: _Worker, *, kill: bool) -> None:
        fresh = _Worker(worker.slot)
        fresh.keys = worker.keys
        self._workers[worker.slot] = fresh
        for key in worker.keys:
            self._home[key] = fresh
        self.restarts += 1
        log.warning("planner worker %d replaced (%s)", worker.slot, "hung" if kill else "died")
        if kill:
            # ProcessPoolExecutor cannot cancel a running call; ending its process is the only way out
            for process in list(getattr(worker.executor, "_processes", {}).values()):
                process.terminate()
        worker.executor.shutdown(wait=False, cancel_futures=True)

    def shutdown(self) -> None:
        """Stop every worker process (blocking: call it through ``asyncio.to_thread``)."""
        for worker in self._workers:
            worker.executor.shutdown(wait=True, cancel_futures=True)
