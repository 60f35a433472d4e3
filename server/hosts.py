"""AI controllers in worker processes ("controller hosts"), so their Python work does not hold the server's GIL.

Trackers running in threads of the server process take its GIL for about half a millisecond per kart and tick;
with many races the event loop then waits for the GIL before its ticks. A host is one spawned process that
runs the controllers of many karts (from any races), each in its own :class:`~server.drivers.DriverThread`
there, so a slow or hung controller delays no other kart. Per kart, the server sends the newest observation
(newest wins: nothing queues behind a slow controller) and gets back its inputs; plans from the planner
workers are forwarded to the host's copy of the controller (every message is a dataclass of
:mod:`server.host_messages`). One thread per host in the server process does all the talking, so the tick task
never blocks on a pipe.

A kart whose answer is overdue is hung: the tick task retires it (its thread in the host is abandoned). A host
that dies is restarted and its karts are built and reset again.

:class:`HostedKart` is the tick task's handle on such a kart (the :class:`~server.drivers.KartWorker` interface).
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import threading
import time
from collections.abc import Callable
from multiprocessing.connection import Connection, wait

from arena.lifeline import die_with_parent
from controllers.base import Controller, RaceContext
from controllers.plan import Plan
from server.controller_params import build_controller
from server.drivers import DriverThread, KartDriver
from server.host_messages import (
    Act,
    ActionOut,
    Close,
    DeliverPlan,
    Error,
    Failed,
    FromHost,
    Open,
    Ready,
    Stop,
    ToHost,
)
from server.loop import step_below_realtime
from server.race_config import KartEntry
from server.warmup import warm_drivers
from sim_core.observation import Observation

log = logging.getLogger(__name__)


# ----------------------------------------------------------------------------------------- host process side
def _host_main(conn: Connection) -> None:
    """The host process: one driver thread per kart; messages in, outcomes out, until told to stop."""
    send_lock = threading.Lock()
    threads: dict[int, DriverThread] = {}

    def report(event: FromHost) -> None:
        with send_lock, contextlib.suppress(OSError, ValueError):
            conn.send(event)

    while True:
        try:
            message: ToHost = conn.recv()
        except (EOFError, OSError):
            return  # the server went away
        match message:
            case Act(kart, step, observation) if kart in threads:
                threads[kart].submit(step, observation)
            case Open(kart, controller_name, factory, context):
                try:
                    controller = build_controller(factory)
                except Exception as exc:
                    report(Failed(kart, f"construction raised {type(exc).__name__}: {exc}"))
                    continue
                driver = KartDriver(KartEntry(context.ego, controller_name, controller_name), controller)
                threads[kart] = DriverThread(driver, context, f"kart-{kart}", report, kart)
            case DeliverPlan(kart, plan) if kart in threads:
                planning = threads[kart].driver.planning
                if planning is not None:
                    planning.deliver(plan)
            case Close(kart) if kart in threads:
                threads.pop(kart).retire()
            case Stop():
                return


def _host_entry(conn: Connection) -> None:
    die_with_parent()  # no orphan after a server crash
    step_below_realtime()
    from controllers.registry import REGISTRY

    warm_drivers(REGISTRY.values())  # load the compiled kernels the registered controllers use
    _host_main(conn)


# ----------------------------------------------------------------------------------------- server side
class HostedKart:
    """The tick task's handle on one kart whose controller runs in a host."""

    def __init__(
        self,
        host: ControllerHost,
        kart_id: int,
        driver: KartDriver,
        factory: Callable[[], Controller],
        context: RaceContext,
    ) -> None:
        self.host = host
        self.kart_id = kart_id
        self.driver = driver
        self.factory = factory
        self.context = context
        self.resetting = True
        self.latest: tuple[int, float, float] | None = None
        self.waiting_since: float | None = time.monotonic()  # the oldest unanswered request (or the reset)

    @property
    def busy_since(self) -> float | None:
        """Since when an answer (or the end of the reset) has been awaited; None when nothing is owed."""
        return self.waiting_since

    def submit(self, step: int, observation: Observation) -> None:
        """Hand over the kart's observation of race step ``step`` (newest wins)."""
        if self.waiting_since is None:
            self.waiting_since = time.monotonic()
        self.host.send_act(Act(self.kart_id, step, observation))

    def deliver(self, plan: Plan) -> None:
        """Forward a plan to the host's copy of the controller."""
        self.host.send(DeliverPlan(self.kart_id, plan))

    def retire(self) -> None:
        """Stop using this kart's controller (its thread in the host is abandoned)."""
        self.host.detach(self.kart_id)

    def reopen(self) -> None:
        """Build and reset the controller (again) in the host."""
        self.resetting = True
        self.waiting_since = time.monotonic()
        name = self.driver.controller_name
        self.host.send(Open(self.kart_id, name, self.factory, self.context))

    def outcome(self, event: FromHost) -> None:
        """An event from the host (on the host's pump thread)."""
        driver = self.driver
        match event:
            case ActionOut(_, step, steer, throttle):
                self.latest = (step, steer, throttle)
            case Ready():
                driver.ready = True
                self.resetting = False
            case Failed(_, error):
                driver.exceptions += 1
                driver.disabled = True
                driver.record_error(error, traceback=False)
                self.resetting = False
            case Error(_, error):
                driver.exceptions += 1
                driver.record_error(error, traceback=False)
        self.waiting_since = None


class ControllerHost:
    """One host process and the server-side thread that feeds it and reads its answers."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._karts: dict[int, HostedKart] = {}
        self._lock = threading.Lock()
        self._control: list[ToHost] = []
        self._acts: dict[int, Act] = {}
        self.restarts = 0
        self._start()

    def _start(self) -> None:
        self.died = False  # the process ended without being asked to
        self._stopping = False
        self._signalled = False
        context = multiprocessing.get_context("spawn")
        self._conn, child = context.Pipe()
        self.process = context.Process(target=_host_entry, args=(child,), name=self.name, daemon=True)
        self.process.start()
        child.close()
        self._wake_read, self._wake_write = os.pipe()
        args = (self._conn, self._wake_read)
        self._thread = threading.Thread(target=self._pump, args=args, name=f"{self.name}-pump", daemon=True)
        self._thread.start()

    @property
    def load(self) -> int:
        """Karts attached."""
        return len(self._karts)

    def attach(
        self,
        kart_id: int,
        driver: KartDriver,
        factory: Callable[[], Controller],
        context: RaceContext,
    ) -> HostedKart:
        """Build and reset a kart's controller in the host (outcomes arrive on the handle)."""
        kart = HostedKart(self, kart_id, driver, factory, context)
        self._karts[kart_id] = kart
        kart.reopen()
        return kart

    def detach(self, kart_id: int) -> None:
        """Forget a kart."""
        if self._karts.pop(kart_id, None) is not None:
            self.send(Close(kart_id))

    def send(self, message: ToHost) -> None:
        """Queue a control message (sent in order, before pending observations)."""
        with self._lock:
            self._control.append(message)
        self._wake()

    def send_act(self, act: Act) -> None:
        """Queue a kart's newest observation (replacing one not yet sent)."""
        with self._lock:
            self._acts[act.kart] = act
        self._wake()

    def _wake(self) -> None:
        if not self._signalled:  # one wake-up byte per batch: a syscall per kart and tick would add up
            self._signalled = True
            with contextlib.suppress(OSError):
                os.write(self._wake_write, b"x")

    def restart(self) -> None:
        """Start a fresh process (the old one died); every attached kart is built and reset again."""
        self.restarts += 1
        log.warning("controller host %s died; restarting it", self.name)
        self._stop_process(kill=True)
        with self._lock:
            self._control.clear()
            self._acts.clear()
        self._start()
        for kart in self._karts.values():
            kart.driver.worker_restarts += 1
            kart.driver.record_error(f"its controller host process died (restart {self.restarts})", traceback=False)
            kart.reopen()

    def _stop_process(self, *, kill: bool) -> None:
        self._stopping = True
        if kill:
            self.process.kill()
        else:
            with contextlib.suppress(OSError, ValueError):
                self._conn.send(Stop())
        self.process.join(5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join(5)
        for fd in (self._wake_read, self._wake_write):
            with contextlib.suppress(OSError):
                os.close(fd)
        with contextlib.suppress(OSError):
            self._conn.close()

    def close(self) -> None:
        """Stop the host (blocking: call it through ``asyncio.to_thread``)."""
        self._karts.clear()
        self._stop_process(kill=False)

    def _pump(self, conn: Connection, wake: int) -> None:
        try:
            while True:
                ready = wait([conn, wake])
                if wake in ready:
                    os.read(wake, 4096)
                    self._signalled = False
                    with self._lock:
                        control, self._control = self._control, []
                        acts, self._acts = self._acts, {}
                    for message in control:
                        conn.send(message)
                    for act in acts.values():
                        conn.send(act)
                if conn in ready:
                    while conn.poll():
                        event: FromHost = conn.recv()
                        kart = self._karts.get(event.kart)
                        if kart is not None:
                            kart.outcome(event)
        except (EOFError, OSError, ValueError):
            if not self._stopping:
                self.died = True


class ControllerHosts:
    """``n`` hosts; a kart goes to the least-loaded one."""

    def __init__(self, n: int) -> None:
        self.hosts = [ControllerHost(f"controller-host-{i}") for i in range(n)]
        self._next_id = 0

    def attach(
        self,
        driver: KartDriver,
        factory: Callable[[], Controller],
        context: RaceContext,
    ) -> HostedKart:
        """Run ``driver``'s controller (built by ``factory``) in a host."""
        self._next_id += 1
        host = min(self.hosts, key=lambda h: h.load)
        return host.attach(self._next_id, driver, factory, context)

    def revive(self) -> None:
        """Restart hosts that died."""
        for host in self.hosts:
            if host.died:
                host.restart()

    def close(self) -> None:
        """Stop every host (blocking)."""
        for host in self.hosts:
            host.close()
