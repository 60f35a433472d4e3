"""The drivers of a live race: per kart an AI controller or a human on the drive websocket, and the thread
that runs an AI controller off the tick task.

The tick task never waits for a controller. Each tick it hands the newest observation of each AI kart to its
:class:`KartWorker` (a :class:`DriverThread` here, or a kart in a controller host process,
:mod:`server.hosts`) and reads the newest inputs it has finished (one tick of latency). A kart whose controller
raises, hangs or is late holds its last input; after a while without a fresh input it brakes. Every such event
is counted on the kart (:attr:`KartDriver.faults`).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any, Protocol, runtime_checkable

from controllers.base import Controller, PlanningDriver, RaceContext, Tracker
from controllers.plan import Plan
from controllers.registry import ControllerSpec
from server.controller_params import build_controller, resolve_factory
from server.host_messages import ActionOut, Error, Failed, FromHost, Ready
from server.loop import step_below_realtime
from server.race_config import KartEntry
from server.results import DriverFaults
from sim_core.observation import Observation
from sim_core.params import DT

log = logging.getLogger(__name__)

BRAKE_DEADBAND = 0.05  # [m/s] below this speed "brake" means no pedal (a held brake reverses from standstill)


def brake_throttle(speed: float) -> float:
    """The throttle that brings a kart moving at ``speed`` [m/s] to rest without reversing."""
    if speed > BRAKE_DEADBAND:
        return -1.0
    if speed < -BRAKE_DEADBAND:
        return 1.0
    return 0.0


@runtime_checkable
class SeparateTracker(Protocol):
    """A planning driver whose tracker can be reset on its own (``HierarchicalController.tracker``).

    The live server's planner runs in a planner worker, so the tick side resets only the tracker; a planning
    driver without this capability is reset whole (its planner's reset is then wasted work, not wrong).
    """

    tracker: Tracker


class KartDriver:
    """One kart's driver in a live race, its held inputs and its fault record.

    Counters are written by one side each (``exceptions`` by the controller's worker, the rest by the tick
    task), so no lock is needed. The server asks what the controller can do once, here: :attr:`planning` is
    the controller when it plans off the tick (:class:`~controllers.base.PlanningDriver`), else ``None``.
    """

    def __init__(self, entry: KartEntry, controller: Controller | None, token: str | None = None) -> None:
        self.entry = entry
        self.index = entry.index
        self.name = entry.name
        self.controller_name = entry.controller
        self.human = entry.human  # a person (or a client program) drives this kart over the websocket
        self.controller = controller
        self.planning: PlanningDriver | None = controller if isinstance(controller, PlanningDriver) else None
        self.token = token
        rate = controller.rate_hz if controller is not None else 1.0 / DT
        self.every = max(1, round(1.0 / (DT * rate)))  # decide every this many ticks
        # AI side
        self.ready = False  # reset done
        self.disabled = False  # reset failed or a call hung: no more calls
        self.exceptions = 0
        self.missed = 0  # ticks that found no fresh input for an observation handed over
        self.hangs = 0
        self.planner_faults = 0  # plans that failed or timed out
        self.worker_restarts = 0  # times the process running its controller died and was restarted
        self.last_error: str | None = None
        self.submitted_step = -1  # race step of the last observation handed to the thread
        # inputs
        self.steer = 0.0
        self.throttle = 0.0
        self.fresh_step = -1  # race step whose observation produced the held input (AI; the grid's is step 0)
        self.braking = False
        self.waypoints: tuple[tuple[float, float], ...] = ()  # positions of the active plan's ego waypoints
        self.predicted: tuple[tuple[float, float], ...] = ()  # and of its predictions for the other karts
        # human side
        self.connected = False
        self.ever_connected = False
        self.view_ready = False  # its driver's view has loaded (at once for clients without a view)
        self.input: tuple[float, float, int | None] | None = None  # newest (steer, throttle, seq) received
        self.input_at: float | None = None  # [s] time.monotonic() of the newest input
        self.applied_seq: int | None = None  # seq of the input applied at the last tick

    @property
    def faults(self) -> int:
        """Exceptions, hangs, missed deadlines, failed plans and worker restarts of this kart's controller."""
        return self.exceptions + self.hangs + self.missed + self.planner_faults + self.worker_restarts

    @property
    def plans_applied(self) -> int:
        """Plans its planning driver has received (0 for other controllers)."""
        return self.planning.plans_applied if self.planning is not None else 0

    def fault_record(self) -> DriverFaults:
        """Its faults so far, as a record."""
        return DriverFaults(
            exceptions=self.exceptions,
            hangs=self.hangs,
            missed_deadlines=self.missed,
            planner_faults=self.planner_faults,
            worker_restarts=self.worker_restarts,
            plans_applied=self.plans_applied,
            disabled=self.disabled,
            last_error=self.last_error,
        )

    def reset(self, context: RaceContext) -> None:
        """Prepare the controller for the race (planning drivers: the tracking side; planners live in workers)."""
        assert self.controller is not None
        if isinstance(self.planning, SeparateTracker):
            self.planning.tracker.reset(context)
        else:
            self.controller.reset(context)

    def compute(self, observation: Observation) -> tuple[float, float]:
        """The controller's inputs for ``observation`` (raises what the controller raises)."""
        if self.planning is not None:
            action = self.planning.track(observation)
        else:
            assert self.controller is not None
            action = self.controller.act(observation)
        steer, throttle = float(action.steer), float(action.throttle)
        if not (math.isfinite(steer) and math.isfinite(throttle)):
            raise ValueError(f"non-finite action ({steer}, {throttle})")
        return steer, throttle

    def take_human_input(self, now: float, speed: float, timeout: float) -> None:
        """Hold the newest input received (``now``: ``time.monotonic()``); after ``timeout`` [s] of silence brake
        from ``speed`` [m/s], holding the steer."""
        received = self.input
        if received is None or self.input_at is None or now - self.input_at > timeout:
            self.throttle = brake_throttle(speed)
            self.braking = True
            return
        self.steer, self.throttle, self.applied_seq = received
        self.braking = False

    def take_ai_input(
        self, latest: tuple[int, float, float] | None, step: int, speed: float, hold_s: float, *, finished: bool
    ) -> None:
        """Hold the controller's newest answer ``latest`` (observation step, steer, throttle) at race step
        ``step``, counting a missed deadline when the last observation handed over has no answer yet; brake from
        ``speed`` [m/s] when disabled, not ready, or without a fresh input for ``hold_s`` [s] of race time. A
        ``finished`` kart is asked nothing more: it holds its last input, as in a headless race (the simulation
        parks it)."""
        if latest is not None and latest[0] > self.fresh_step:
            self.fresh_step, self.steer, self.throttle = latest
        if self.submitted_step > self.fresh_step:
            self.missed += 1
        if finished:
            return
        hold_ticks = max(round(hold_s / DT), 2 * self.every)
        if self.disabled or not self.ready or step - self.fresh_step > hold_ticks:
            self.throttle = brake_throttle(speed)
            self.braking = True
        else:
            self.braking = False

    def record_error(self, what: str, *, traceback: bool = True) -> None:
        """Remember the latest fault's description (the first one is also logged, with the traceback of the
        exception being handled when ``traceback``)."""
        if self.last_error is None:
            log.warning("kart %d (%s): %s", self.index, self.controller_name, what, exc_info=traceback)
        self.last_error = what


def make_driver(entry: KartEntry, token: str | None, catalogue: Mapping[str, ControllerSpec[Any]]) -> KartDriver:
    """Kart ``entry``'s driver: a human's (``token``: its drive token), or its controller from ``catalogue`` built
    here with the entry's parameters. A controller whose construction raises leaves the kart's driver disabled,
    with the error recorded (the race goes on; the kart brakes)."""
    if entry.human:
        return KartDriver(entry, None, token)
    try:
        controller = build_controller(resolve_factory(catalogue[entry.controller], entry.params))
    except Exception as exc:
        driver = KartDriver(entry, None)
        driver.exceptions += 1
        driver.disabled = True
        driver.record_error(f"construction raised {type(exc).__name__}: {exc}")
        return driver
    return KartDriver(entry, controller)


class KartWorker(Protocol):
    """Where an AI kart's controller runs: a :class:`DriverThread`, or a kart in a controller host process
    (:class:`server.hosts.HostedKart`)."""

    resetting: bool  # the controller is being built and reset
    latest: tuple[int, float, float] | None  # the newest answer: (observation step, steer, throttle)

    @property
    def busy_since(self) -> float | None:
        """``time.monotonic()`` when the call running now started (None when idle)."""

    def submit(self, step: int, observation: Observation) -> None:
        """Hand over the kart's observation of race step ``step`` (newest wins, never blocks)."""

    def deliver(self, plan: Plan) -> None:
        """Make ``plan`` the active plan of the controller copy that runs there."""

    def retire(self) -> None:
        """Stop using it (a call still running is abandoned)."""


class DriverThread:
    """Runs one AI kart's controller in a daemon thread: resets it, then computes inputs for each handed-over
    observation.

    :meth:`submit` never blocks (the newest observation replaces one not yet taken); the answer lands in
    :attr:`latest` as ``(observation step, steer, throttle)``. :attr:`busy_since` tells since when a call has
    been running, so the tick task can declare it hung and :meth:`retire` the thread. One thread per kart: a
    controller that hangs delays no other kart. ``report`` (in controller hosts) also gets every outcome as a
    host message for kart ``kart`` (:class:`~server.host_messages.Ready`, ``Failed``, ``ActionOut``, ``Error``).
    """

    def __init__(
        self,
        driver: KartDriver,
        context: RaceContext,
        name: str,
        report: Callable[[FromHost], None] | None = None,
        kart: int = -1,
    ) -> None:
        self.driver = driver
        self._context = context
        self._report = report or (lambda event: None)
        self._kart = kart
        self._job: tuple[int, Observation] | None = None
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self.retired = False
        self.resetting = True
        self.busy_since: float | None = None  # time.monotonic() at the start of the running call
        self.latest: tuple[int, float, float] | None = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def submit(self, step: int, observation: Observation) -> None:
        """Hand over the kart's observation of race step ``step`` (newest wins)."""
        with self._lock:
            self._job = (step, observation)
        self._wake.set()

    def retire(self) -> None:
        """Stop using this thread; a call still running is abandoned and its answer discarded."""
        self.retired = True
        self._wake.set()

    def deliver(self, plan: Plan) -> None:
        """Nothing to do: the thread runs the session's own controller object, which already has the plan."""

    def _reset(self) -> None:
        driver = self.driver
        self.busy_since = time.monotonic()
        try:
            driver.reset(self._context)
        except Exception as exc:
            driver.exceptions += 1
            driver.disabled = True
            driver.record_error(f"reset raised {type(exc).__name__}: {exc}")
            self._report(Failed(self._kart, driver.last_error or "reset failed"))
        else:
            driver.ready = not self.retired
            self._report(Ready(self._kart))
        self.busy_since = None

    def _run(self) -> None:
        step_below_realtime()
        driver = self.driver
        if not driver.disabled:
            self._reset()
        self.resetting = False
        while not self.retired and driver.ready:
            self._wake.wait()
            self._wake.clear()
            with self._lock:
                job, self._job = self._job, None
            if job is None or self.retired:
                continue
            step, observation = job
            self.busy_since = time.monotonic()
            result: tuple[int, float, float] | None = None
            try:
                steer, throttle = driver.compute(observation)
            except Exception as exc:
                driver.exceptions += 1
                what = f"act raised {type(exc).__name__}: {exc}"
                driver.record_error(what)
                self._report(Error(self._kart, what))
            else:
                result = (step, steer, throttle)
            self.busy_since = None
            if result is not None and not self.retired:  # a hung call that came back is not used
                self.latest = result
                self._report(ActionOut(self._kart, *result))
