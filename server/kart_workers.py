"""Where one race's AI controllers run: a worker per AI kart (a kart in a controller host process,
:mod:`server.hosts`, or a thread of the server, :class:`server.drivers.DriverThread`), fed each kart's
observations when its controller is due, checked for hangs, and retired when the race ends.

The race session (:mod:`server.session`) owns one :class:`KartWorkers`; nothing here waits for a controller:
answers are read from each worker's ``latest`` (never blocking the tick; a lockstep session polls
:meth:`KartWorkers.answered` between ticks).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence

from controllers.base import Controller, RaceContext
from controllers.plan import Plan
from server.drivers import DriverThread, KartDriver, KartWorker
from server.hosts import ControllerHosts
from server.settings import Settings
from sim_core.observation import Observation

log = logging.getLogger(__name__)


class KartWorkers:
    """The AI karts' controller workers of race ``race_id``, by kart index (a kart whose controller hung has
    none: it brakes)."""

    def __init__(
        self, race_id: str, drivers: Sequence[KartDriver], hosts: ControllerHosts | None, settings: Settings
    ) -> None:
        self.race_id = race_id
        self.drivers = drivers
        self.hosts = hosts
        self.settings = settings
        self._workers: dict[int, KartWorker] = {}

    def attach(self, driver: KartDriver, factory: Callable[[], Controller], context: RaceContext) -> None:
        """Start ``driver``'s controller where AI controllers run (a host process, else a thread)."""
        if self.hosts is not None:
            self._workers[driver.index] = self.hosts.attach(driver, factory, context)
        else:
            self._workers[driver.index] = DriverThread(driver, context, f"race-{self.race_id}-kart{driver.index}")

    @property
    def resetting(self) -> bool:
        """Whether a controller is still being built and reset."""
        return any(w.resetting for w in self._workers.values())

    def latest(self, kart: int) -> tuple[int, float, float] | None:
        """Kart ``kart``'s newest answer (observation step, steer, throttle); None: none, or no worker."""
        worker = self._workers.get(kart)
        return worker.latest if worker is not None else None

    def submit(self, step: int, observations: Sequence[Observation]) -> None:
        """Hand each kart whose controller is due at race step ``step`` its observation (never blocks)."""
        for k, worker in self._workers.items():
            d = self.drivers[k]
            if d.ready and not d.disabled and step % d.every == 0 and not observations[k].me.finished:
                d.submitted_step = step
                worker.submit(step, observations[k])

    def answered(self) -> bool:
        """Whether every working AI kart has answered the last observation handed to it."""
        for k, worker in self._workers.items():
            latest, d = worker.latest, self.drivers[k]
            if not d.disabled and d.submitted_step >= 0 and (latest is None or latest[0] < d.submitted_step):
                return False
        return True

    def deliver(self, kart: int, plan: Plan) -> None:
        """Make ``plan`` the active plan of kart ``kart``'s controller copy in its worker (if it has one)."""
        worker = self._workers.get(kart)
        if worker is not None:
            worker.deliver(plan)

    def check_hang(self) -> None:
        """Revive crashed host processes; disable (the kart brakes) and retire each worker whose call has run
        longer than allowed (``controller_reset_s`` for a reset, ``controller_hang_s`` for an answer)."""
        if self.hosts is not None:
            self.hosts.revive()
        now = time.monotonic()
        for k, worker in list(self._workers.items()):
            since = worker.busy_since
            limit = self.settings.controller_reset_s if worker.resetting else self.settings.controller_hang_s
            if since is None or now - since <= limit:
                continue
            d = self.drivers[k]
            d.hangs += 1
            d.disabled = True
            d.last_error = f"{'reset' if worker.resetting else 'act'} did not return within {limit:g} s"
            log.warning("race %s kart %d (%s): %s; the kart brakes", self.race_id, k, d.controller_name, d.last_error)
            worker.retire()
            del self._workers[k]

    def retire_all(self) -> None:
        """Stop using every worker (the race is over)."""
        for worker in self._workers.values():
            worker.retire()
        self._workers.clear()
