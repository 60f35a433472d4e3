"""A race's side of off-tick planning: per kart that plans off the tick (a
:class:`~controllers.base.PlanningDriver`), its planner is opened in a planner worker before the start, a plan
is requested whenever the driver wants one, and finished plans are collected at the next tick, each with the
race time it becomes due: its request's race time plus the driver's ``plan_latency``, as a headless race applies
it (:class:`~controllers.hierarchical.HierarchicalController`). A request that takes longer than
``plan_timeout_s`` is given up (and a stuck worker replaced); every failure is counted on the kart as a planner
fault.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Iterator, Sequence

from controllers.plan import Plan
from server.drivers import KartDriver
from server.host_messages import PlannerSetup
from server.planning import PlannerPool
from sim_core.observation import Observation


class PlanRequests:
    """The plan requests of race ``race_id`` to the shared planner workers."""

    def __init__(self, race_id: str, pool: PlannerPool, plan_timeout_s: float) -> None:
        self.race_id = race_id
        self._pool = pool
        self._timeout = plan_timeout_s
        # kart -> (request, wall time sent, race time it becomes due)
        self._tasks: dict[int, tuple[asyncio.Task[Plan], float, float]] = {}
        self._keys: list[str] = []

    def _key(self, d: KartDriver) -> str:
        return f"{self.race_id}/{d.index}"

    async def open(self, d: KartDriver, setup: PlannerSetup, timeout: float) -> None:
        """Build the planner of ``d`` in its worker (a failure is counted and the kart races without plans)."""
        key = self._key(d)
        self._keys.append(key)
        try:
            await asyncio.wait_for(self._pool.open(key, setup), timeout)
        except Exception as exc:
            d.planner_faults += 1
            d.record_error(f"planner setup failed: {type(exc).__name__}: {exc}")

    def request(self, drivers: Sequence[KartDriver], observations: Sequence[Observation]) -> None:
        """Send a request for each planning driver that wants a plan and has none pending; give up late ones."""
        now = time.monotonic()
        for d in drivers:
            planning = d.planning
            if planning is None or d.disabled:
                continue
            pending = self._tasks.get(d.index)
            if pending is not None:
                if now - pending[1] > self._timeout:
                    pending[0].cancel()
                    del self._tasks[d.index]
                    d.planner_faults += 1
                    d.last_error = f"no plan within {self._timeout:g} s"
                    self._pool.replace_if_stuck(self._key(d), self._timeout)
                continue
            observation = observations[d.index]
            if observation.me.finished or not planning.wants_plan(observation.time):
                continue
            planning.mark_plan_requested(observation.time)
            task = asyncio.get_running_loop().create_task(self._pool.plan(self._key(d), observation))
            self._tasks[d.index] = (task, now, observation.time + planning.plan_latency)

    def collect(self, drivers: Sequence[KartDriver]) -> Iterator[tuple[KartDriver, Plan, float]]:
        """The plans that came back since the last call, by driver, with the race time each becomes due (failed
        requests are counted instead)."""
        for kart, (task, _sent, due) in list(self._tasks.items()):
            if not task.done():
                continue
            del self._tasks[kart]
            d = drivers[kart]
            if task.cancelled():
                continue
            exc = task.exception()
            if exc is not None:
                d.planner_faults += 1
                d.last_error = f"planner raised {type(exc).__name__}: {exc}"
                continue
            yield d, task.result(), due

    def due_by(self, race_time: float) -> bool:
        """Whether a plan due by ``race_time`` is still being computed (it comes back to :meth:`collect`)."""
        return any(due <= race_time + 1e-9 for _task, _sent, due in self._tasks.values())

    def close(self) -> None:
        """Cancel pending requests and forget the race's planners in their workers."""
        for task, _sent, _due in self._tasks.values():
            task.cancel()
        self._tasks.clear()
        if self._keys:
            self._pool.close(tuple(self._keys))
            self._keys.clear()
