"""A live race: one ``World`` (one race) stepped at 50 Hz by an asyncio task, with its drivers, planners,
3D scene and subscribers.

Life of a race (:class:`~server.status.RaceStatus`): ``starting`` (world built, controllers reset, planners
built in their worker, scene opened) -> ``waiting`` and ``countdown`` (only with human karts: until every driver
has connected and its view is ready, or a timeout; then a countdown during which nothing moves) -> ``running``
-> ``finished`` (the referee's rules: everyone finished or the time limit), ``stopped`` (on request) or
``aborted`` (server shutdown). The result (:class:`~server.results.RaceRecord`) and the replay are
then stored; the race stays live for a while so viewers see the end.

Each tick (see :mod:`server.ticks` for the schedule) does only bounded work on the event loop: deliver plans
that came back from the planner workers (:mod:`server.plan_requests`), read the newest controller inputs (never
waiting for them), step the world, hand the new observations to the karts' controller workers
(:mod:`server.kart_workers`), request due plans, build the frame (:mod:`server.frames`) and push it to the scene
and the subscribers.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Collection, Mapping, Sequence
from datetime import datetime
from typing import Any

import numpy as np

from controllers.plan import Plan
from controllers.replay import ReplayRecorder, apply_plan_targets
from server.absent_drivers import DriverWait, StuckWatch, not_ready
from server.broadcast import Broadcast
from server.controller_params import resolve_factory
from server.db import utc_now
from server.drivers import KartDriver, make_driver
from server.frames import TelemetryMessage, build_frame, replay_json
from server.host_messages import PlannerSetup
from server.kart_workers import KartWorkers
from server.plan_requests import PlanRequests
from server.race_config import RaceConfig, build_world, driver_context
from server.results import RaceRecord, RaceSetup, live_race_manifest, race_record
from server.services import RaceServices, Scene
from server.snapshot import DriverState, RaceSnapshot, Standing
from server.status import RaceStatus
from server.ticks import TickSchedule, TickSummary, sleep_until, spread_start
from sim_core import state as st
from sim_core.laps import LapTimer
from sim_core.observation import Observation, observe
from sim_core.params import DT, SimParams, kart_preset
from sim_core.world import World, grid_lanes
from web.frame import RaceFrame

log = logging.getLogger(__name__)

LOCKSTEP_POLL_S = 0.0005  # [s] a lockstep tick polls its controllers' answers this often
HANG_POLL_S = 0.02  # [s] how often a starting race checks its controllers' resets
GRID_PUBLISH_S = 0.1  # [s] how often a race waiting for its drivers or counting down publishes a frame


class RaceSession:
    """One live race (see the module docstring). Create, then :meth:`start`; :meth:`stop` ends it early."""

    def __init__(self, race_id: str, config: RaceConfig, tokens: Mapping[int, str], services: RaceServices) -> None:
        self.id = race_id
        self.config = config
        self.services = services
        self.settings = services.settings
        self.created_at: datetime = utc_now()
        self.status = RaceStatus.STARTING
        self.drivers = [make_driver(entry, tokens.get(entry.index), services.catalogue) for entry in config.karts]
        self.world: World | None = None
        self.frame: RaceFrame | None = None
        self.updates = Broadcast()
        self.schedule: TickSchedule | None = None
        self.scene: Scene | None = None
        self.result: RaceRecord | None = None
        self.replay = ReplayRecorder(config.track.name, len(self.drivers))
        self.laps = LapTimer(len(self.drivers), config.track.n_checkpoints)
        self.plans_version = 0
        self.error: str | None = None
        self.end_reason: str | None = None  # why the race ended (stored with the result)
        self._stuck = StuckWatch(self.settings)
        self._workers = KartWorkers(race_id, self.drivers, services.hosts, self.settings)  # the AI controllers
        self._plans = PlanRequests(race_id, services.planners, self.settings.plan_timeout_s)
        self._due: dict[int, tuple[Plan, float]] = {}  # kart -> (plan collected, race time it takes effect)
        self._actions = np.zeros((1, len(self.drivers), 2))
        self._conditions = config.drawn()  # launch delays, grid, start wear and the AI drivers' imprecision
        self._hands = self._conditions.imprecision()
        self._telemetry = TelemetryMessage()
        self._countdown: float | None = None  # [s] left before the start, while counting down
        self._finished = 0  # karts finished at the last tick
        self._stop_status: RaceStatus | None = None
        self._stop = asyncio.Event()
        self._close = asyncio.Event()
        self.task: asyncio.Task[None] | None = None
        self.on_closed: Callable[[RaceSession], None] | None = None
        self.other_starts: Callable[[], list[float]] = list  # schedule starts of the other running races

    # ------------------------------------------------------------------ control
    def start(self) -> None:
        """Start the race's task on the running event loop."""
        self.task = asyncio.get_running_loop().create_task(self._run(), name=f"race-{self.id}")

    @property
    def live(self) -> bool:
        """Whether the race has not ended yet."""
        return self.status.live

    def stop(self, status: RaceStatus = RaceStatus.STOPPED, reason: str = "stopped on request") -> bool:
        """End the race at the next tick with ``status`` for ``reason``; False if already over."""
        if not self.live or self._stop_status is not None:
            return False
        self._stop_status = status
        self.end_reason = reason
        self._stop.set()
        return True

    def close(self) -> None:
        """End the race (as ``aborted`` if live) and drop it without lingering (server shutdown)."""
        self.stop(RaceStatus.ABORTED, "the server shut down")
        self._close.set()

    async def wait_status(self, statuses: Collection[RaceStatus]) -> None:
        """Wait until the race's status is one of ``statuses``."""
        seen = -1
        while self.status not in statuses:
            seen = await self.updates.wait(seen)

    # ------------------------------------------------------------------ human drivers
    def drive_input(self, kart: int, steer: float, throttle: float, seq: int | None) -> None:
        """The newest input of human kart ``kart`` (applied at the next tick)."""
        driver = self.drivers[kart]
        driver.input = (steer, throttle, seq)
        driver.input_at = time.monotonic()

    def waiting_for(self) -> list[KartDriver]:
        """The human drivers the race still waits for (not connected yet, or their view not ready)."""
        if self.status not in (RaceStatus.STARTING, RaceStatus.WAITING):
            return []
        return not_ready(self.drivers)

    # ------------------------------------------------------------------ views
    def telemetry_message(self) -> str | None:
        """The current frame as a telemetry JSON message (built once per frame for every subscriber)."""
        frame = self.frame
        return self._telemetry.of(frame) if frame is not None else None

    def replay_json(self) -> dict[str, Any]:
        """The replay so far in the headless format (``controllers.replay.Replay``) plus the race id and karts."""
        return replay_json(self.replay.replay(), self.id, self.config.karts)

    def tick_stats(self) -> TickSummary | None:
        """Tick timing (see :class:`server.ticks.TickSummary`), or ``None`` before the first tick."""
        return self.schedule.summary() if self.schedule is not None else None

    def snapshot(self, *, ticks: bool = True) -> RaceSnapshot:
        """The race now, as the API shows it (the tick statistics, percentiles over 3,000 ticks, when ``ticks``)."""
        frame = self.frame
        config = self.config
        karts = sorted(frame.karts, key=lambda k: k.position) if frame is not None else []
        return RaceSnapshot(
            id=self.id,
            created_at=self.created_at,
            status=self.status,
            track=config.track_name,
            laps=config.laps,
            seed=config.seed,
            kart_preset=config.kart_preset,
            start_lanes=grid_lanes(len(config.karts), config.start_lanes),
            karts=config.karts,
            time=frame.time if frame is not None else 0.0,
            step=frame.step if frame is not None else 0,
            standings=tuple(Standing.from_frame(k) for k in karts),
            drivers=tuple(
                DriverState(d.entry, d.fault_record(), d.braking, d.connected if d.human else None)
                for d in self.drivers
            ),
            tick_stats=self.tick_stats() if ticks else None,
            winner=self.result.winner if self.result is not None else None,
            error=self.error,
            recorded=self.result is not None and not self.live,
        )

    # ------------------------------------------------------------------ the race task
    async def _run(self) -> None:
        try:
            await self._prepare()
            if self._stop_status is None and any(d.human for d in self.drivers):
                await self._wait_for_humans()
                if self._stop_status is None:
                    await self._count_down()
            if self._stop_status is None:
                await self._race()
            await self._end(self._stop_status or RaceStatus.FINISHED)
        except asyncio.CancelledError:
            await self._end(RaceStatus.ABORTED)
            raise
        except Exception as exc:
            log.exception("race %s failed", self.id)
            self.error = self.end_reason = f"{type(exc).__name__}: {exc}"
            await self._end(RaceStatus.ABORTED)
        finally:
            self._release()
        try:
            await asyncio.wait_for(self._close.wait(), self.settings.keep_finished_s)
        except TimeoutError:
            pass
        finally:
            await self._close_scene()
            if self.on_closed is not None:
                self.on_closed(self)

    async def _prepare(self) -> None:
        config = self.config
        params = SimParams(kart=kart_preset(config.kart_preset))
        self.world = world = await asyncio.to_thread(self._build_world, params)
        self.replay.allocate(int(world.rule_vector[st.RP_TIME_LIMIT_STEPS]) + 1)  # up to the time limit
        contexts = {d.index: driver_context(config, world, d.index) for d in self.drivers if not d.human}
        ai = [d for d in self.drivers if not d.human and not d.disabled]
        opening = []
        for d in ai:
            factory = resolve_factory(self.services.catalogue[d.controller_name], d.entry.params)
            self._workers.attach(d, factory, contexts[d.index])
            if d.planning is not None:
                setup = PlannerSetup(factory, contexts[d.index], self.settings.plan_budget_s)
                opening.append(self._plans.open(d, setup, self.settings.controller_reset_s))
        await asyncio.gather(self._open_scene(), *opening)
        while self._workers.resetting and self._stop_status is None:
            self._workers.check_hang()
            await asyncio.sleep(HANG_POLL_S)
        self._publish()

    def _build_world(self, params: SimParams) -> World:
        humans = [d.human for d in self.drivers]
        return build_world(self.config, params, self._conditions, humans)

    async def _open_scene(self) -> None:
        scene_factory = self.services.scene_factory
        if scene_factory is None:
            return
        label = f"{self.config.track_name} · race {self.id}"
        karts = [(d.name, d.controller_name) for d in self.drivers]
        try:
            self.scene = await asyncio.to_thread(scene_factory, self.config.track, karts, label)
        except Exception:
            log.exception("race %s: the 3D view could not start; racing without it", self.id)

    async def _wait_for_humans(self) -> None:
        """Wait until every human driver has connected and its view is ready, or cancel the race
        (:class:`~server.absent_drivers.DriverWait`)."""
        await self._set_status(RaceStatus.WAITING)
        wait = DriverWait(self.drivers, self.settings, time.monotonic())
        while (over := wait.over(time.monotonic())) is None:
            self._publish()  # the drive pages show whom the race waits for
            if await self._stopped_within(GRID_PUBLISH_S):
                return
        if over.cancel is not None:
            self.stop(RaceStatus.CANCELLED, over.cancel)
        elif over.late:
            log.info("race %s: starting without waiting longer for %s", self.id, ", ".join(over.late))

    async def _count_down(self) -> None:
        """``countdown_s`` of wall time before the start, published in the frames; nothing moves meanwhile."""
        if self.settings.countdown_s <= 0:
            return
        loop = asyncio.get_running_loop()
        go = loop.time() + self.settings.countdown_s
        self._countdown = self.settings.countdown_s
        await self._set_status(RaceStatus.COUNTDOWN)
        while (left := go - loop.time()) > 0:
            self._countdown = left
            self._publish()
            if await self._stopped_within(min(GRID_PUBLISH_S, left)):
                break
        self._countdown = None

    async def _stopped_within(self, seconds: float) -> bool:
        """Wait ``seconds``; True if the race was stopped meanwhile."""
        try:
            await asyncio.wait_for(self._stop.wait(), seconds)
        except TimeoutError:
            return False
        return True

    async def _race(self) -> None:
        assert self.world is not None
        await self._set_status(RaceStatus.RUNNING)
        loop = asyncio.get_running_loop()
        period = DT / self.settings.speedup
        grid = observe(self.world, 0)
        self._submit(grid)  # the first inputs come from the grid, and the first plans, as in a headless race
        self._plans.request(self.drivers, grid)
        t0 = spread_start(loop.time() + period, period, self.other_starts())
        schedule = self.schedule = TickSchedule(t0, period)
        while True:
            await sleep_until(schedule.deadline)
            if self.settings.lockstep:
                await self._await_answers()
            schedule.started(loop.time())
            self._tick()
            schedule.finished(loop.time())
            if self.world.done[0] or self._stop_status is not None:
                return
            self._end_if_stuck()

    async def _await_answers(self) -> None:
        """Lockstep: wait until every AI kart answered its last observation and every plan due by the end of this
        tick has come back, or ``controller_hang_s`` has passed (then the tick goes on as it would without)."""
        assert self.world is not None
        due_by = float(self.world.time[0]) + DT
        limit = time.monotonic() + self.settings.controller_hang_s
        while not self._workers.answered() or self._plans.due_by(due_by):
            if time.monotonic() > limit or self._stop_status is not None:
                return
            await asyncio.sleep(LOCKSTEP_POLL_S)

    def _end_if_stuck(self) -> None:
        """End the race (``finished``, the rest not finished) once no unfinished kart could move for a while
        (:class:`~server.absent_drivers.StuckWatch`)."""
        assert self.world is not None
        finished = self.world.istate[0, :, st.I_FINISHED]
        why = self._stuck.check([d for d in self.drivers if not finished[d.index]], time.monotonic())
        if why is not None:
            self.stop(RaceStatus.FINISHED, why)

    # ------------------------------------------------------------------ one tick
    def _tick(self) -> None:
        world = self.world
        assert world is not None
        self._workers.check_hang()
        for d, plan, due in self._plans.collect(self.drivers):
            self._due[d.index] = (plan, due)
        step = int(world.steps[0])
        speeds = world.fstate[0, :, st.F_SPEED]
        parked = world.istate[0, :, st.I_FINISHED]  # finished karts
        now = time.monotonic()
        settings = self.settings
        for d in self.drivers:
            if d.human:
                d.take_human_input(now, float(speeds[d.index]), settings.drive_timeout_s)
            else:
                latest = self._workers.latest(d.index)
                hold_s = settings.controller_hold_s
                d.take_ai_input(latest, step, float(speeds[d.index]), hold_s, finished=bool(parked[d.index]))
            self._actions[0, d.index] = (d.steer, d.throttle)
        self._apply_conditions(step)
        world.step(self._actions)
        self.laps.observe(world)
        observations = observe(world, 0)
        self._deliver_due(float(world.time[0]))
        self._submit(observations)
        self._plans.request(self.drivers, observations)
        self.replay.record(world, self._actions[0])
        finished = int(world.istate[0, :, st.I_FINISHED].sum())
        if finished != self._finished:  # a finished kart's waypoints disappear from the views
            self._finished = finished
            self.plans_version += 1
        self._publish()

    def _apply_conditions(self, step: int) -> None:
        """The race conditions on the AI karts' commands: each stands until its launch delay, then its commands get
        the drivers' imprecision (a human's launch and hands are their own)."""
        ai = np.array([not d.human for d in self.drivers])
        waiting = ai & ~self._conditions.launched(step)
        self._actions[0, waiting] = 0.0
        if self._hands is not None:
            racing = self.world is not None and self.world.istate[0, :, st.I_FINISHED] == 0
            self._actions[0] = self._hands.perturb(self._actions[0], ai & ~waiting & racing)

    def _submit(self, observations: Sequence[Observation]) -> None:
        assert self.world is not None
        self._workers.submit(int(self.world.steps[0]), observations)

    def _deliver_due(self, now: float) -> None:
        """Apply the plans due by race time ``now`` before the trackers see its observation: a plan takes effect
        its latency after it was asked for, as in a headless race of the same seed, or as it comes if later."""
        for kart, (plan, due) in list(self._due.items()):
            if now >= due - 1e-9:
                del self._due[kart]
                self._deliver(self.drivers[kart], plan)

    def _deliver(self, d: KartDriver, plan: Plan) -> None:
        assert d.planning is not None and self.world is not None
        d.planning.deliver(plan)
        self._workers.deliver(d.index, plan)
        apply_plan_targets(self.world, 0, d.index, plan)  # the referee's delta_r / delta_v, as headless races
        d.waypoints = tuple(w.position for w in plan.ego_waypoints)
        d.predicted = tuple(w.position for ws in plan.opponent_waypoints().values() for w in ws)
        self.plans_version += 1
        self.replay.plan(int(self.world.steps[0]), d.index, plan)

    def _publish(self) -> None:
        if self.world is None:
            self.updates.publish()
            return
        config = self.config
        self.frame = frame = build_frame(
            self.id,
            config.track_name,
            config.laps,
            self.status.value,
            self.world,
            self.drivers,
            self.plans_version,
            round(self._countdown, 2) if self._countdown is not None else None,
        )
        if self.scene is not None:
            try:
                self.scene.update(frame)
            except Exception:
                log.exception("race %s: the 3D view failed; racing without it", self.id)
                scene, self.scene = self.scene, None
                asyncio.get_running_loop().create_task(asyncio.to_thread(scene.close))
        self.updates.publish()

    # ------------------------------------------------------------------ the end
    async def _set_status(self, status: RaceStatus) -> None:
        self.status = status
        self._publish()
        await asyncio.to_thread(self.services.db.set_status, self.id, status)

    async def _end(self, status: RaceStatus) -> None:
        if not self.live:
            return
        record = None
        if self.world is not None:
            config = self.config
            faults = [d.fault_record() for d in self.drivers]
            result = self.world.result(0)
            lanes = grid_lanes(len(config.karts), config.start_lanes)
            setup = RaceSetup(config.seed, config.kart_preset, lanes)
            everyone = all(k.finished for k in result.karts)
            reason = self.end_reason or ("every kart finished" if everyone else "the time limit")
            record = race_record(
                self.id,
                status,
                config.track_name,
                config.laps,
                result,
                config.karts,
                faults,
                setup,
                self.laps.all_lap_times(),
                reason,
                live_race_manifest(config, self.settings.plan_budget_s, self.services.catalogue),
            )
        try:
            if record is None:
                await asyncio.to_thread(self.services.db.set_status, self.id, status)
            else:
                await asyncio.to_thread(self._store, record, self.tick_stats())
        except Exception:
            log.exception("race %s: could not store the result", self.id)
        # only now: whoever sees the race over finds its result and replay stored
        self.result = record
        self.status = status
        self._publish()

    def _store(self, record: RaceRecord, tick_stats: TickSummary | None) -> None:
        self.services.db.finish(self.id, record, tick_stats, self.replay_json())

    def _release(self) -> None:
        self._workers.retire_all()
        self._plans.close()

    async def _close_scene(self) -> None:
        scene, self.scene = self.scene, None
        if scene is not None:
            try:
                await asyncio.to_thread(scene.close)
            except Exception:
                log.exception("race %s: closing the 3D view failed", self.id)
