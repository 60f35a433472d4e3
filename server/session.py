"""A live race: one ``World`` (one race) stepped at 50 Hz by an asyncio task, with its drivers, planners,
3D scene and subscribers.

Life of a race: ``starting`` (world built, controllers reset, planners built in their worker, scene opened)
-> ``waiting`` (only with human karts: until every driver has connected) -> ``running`` -> ``finished`` (the
referee's rules: everyone finished or the time limit), ``stopped`` (on request) or ``aborted`` (server
shutdown). The result and the replay are then stored; the race stays live for a while so viewers see the end.

Each tick (see :mod:`server.ticks` for the schedule) does only bounded work on the event loop: deliver plans
that came back from the planner workers, read the newest controller inputs (never waiting for them), step the
world, hand the new observations to the karts' controller workers (:mod:`server.hosts` processes, or threads:
:mod:`server.drivers`), request due plans, build the :class:`RaceFrame` and push it to the scene and the
subscribers.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from datetime import datetime
from typing import Any, Protocol

import numpy as np

from controllers.base import RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.plan import Plan
from controllers.race import Replay
from controllers.registry import ControllerSpec
from server.db import RaceDatabase, utc_now
from server.drivers import HUMAN, DriverThread, KartDriver, KartWorker, brake_throttle
from server.hosts import ControllerHosts
from server.planning import PlannerPool, PlannerSetup
from server.settings import Settings
from server.ticks import TickSchedule, sleep_until, spread_start
from sim_core import state as st
from sim_core.observation import Observation, observe
from sim_core.params import DT, SimParams, kart_preset
from sim_core.track import Track
from sim_core.world import World
from web.frame import KartFrame, RaceFrame

log = logging.getLogger(__name__)

LIVE = ("starting", "waiting", "running")
HANG_POLL_S = 0.02  # [s] how often a starting race checks its controllers' resets
POSE_COLUMNS = [st.F_X, st.F_Y, st.F_HEADING, st.F_SPEED]


class Scene(Protocol):
    """A race's 3D view (``web.scene.RaceScene``): fed one frame per tick."""

    @property
    def port(self) -> int:
        """The scene server's local TCP port."""

    def update(self, frame: RaceFrame) -> None:
        """Show ``frame`` (cheap, never blocks)."""

    def close(self) -> None:
        """Stop serving (blocking)."""


SceneFactory = Callable[[Track, Sequence[tuple[str, str]], str], Scene]


@dataclass(frozen=True)
class KartEntry:
    """One kart of a race request: display name and controller (registered name or ``human``)."""

    name: str
    controller: str


@dataclass(frozen=True)
class RaceConfig:
    """Everything a race is started from (already validated)."""

    track_name: str
    track: Track
    laps: int
    seed: int
    start_lanes: tuple[int, ...] | None
    kart_preset: str
    karts: tuple[KartEntry, ...]


def frame_dict(frame: RaceFrame) -> dict[str, Any]:
    """``dataclasses.asdict(frame)`` for JSON (tuples stay tuples), in a tenth of the time: frames are flat."""
    return {**frame.__dict__, "karts": [kart.__dict__ for kart in frame.karts]}


class Broadcast:
    """Latest-value notification: :meth:`wait` returns once :attr:`version` has moved past the caller's."""

    def __init__(self) -> None:
        self.version = 0
        self._event = asyncio.Event()

    def publish(self) -> None:
        """Wake every waiter."""
        self.version += 1
        event, self._event = self._event, asyncio.Event()
        event.set()

    async def wait(self, seen: int) -> int:
        """Wait for a version newer than ``seen``; returns it."""
        while self.version == seen:
            await self._event.wait()
        return self.version


class RaceSession:
    """One live race (see the module docstring). Create, then :meth:`start`; :meth:`stop` ends it early."""

    def __init__(
        self,
        race_id: str,
        config: RaceConfig,
        tokens: Mapping[int, str],
        *,
        settings: Settings,
        catalogue: Mapping[str, ControllerSpec],
        pool: PlannerPool,
        hosts: ControllerHosts | None,
        db: RaceDatabase,
        scene_factory: SceneFactory | None,
    ) -> None:
        self.id = race_id
        self.config = config
        self.settings = settings
        self.created_at: datetime = utc_now()
        self.status = "starting"
        self._catalogue = catalogue
        self._pool = pool
        self._hosts = hosts
        self._db = db
        self._scene_factory = scene_factory
        self.drivers = [self._make_driver(k, entry, tokens.get(k)) for k, entry in enumerate(config.karts)]
        self.world: World | None = None
        self.frame: RaceFrame | None = None
        self.updates = Broadcast()
        self.schedule: TickSchedule | None = None
        self.scene: Scene | None = None
        self.result: dict[str, Any] | None = None
        self._poses = np.zeros((0, len(self.drivers), 6))  # per step and kart: x, y, heading, speed, steer, throttle
        self._recorded = 0  # steps in _poses
        self._plans: list[dict[str, Any]] = []  # plans as they were applied (the replay's)
        self.plans_version = 0
        self.error: str | None = None
        self._workers: dict[int, KartWorker] = {}  # AI kart -> where its controller runs
        self._actions = np.zeros((1, len(self.drivers), 2))
        self._plan_tasks: dict[int, tuple[asyncio.Task[Plan], float]] = {}  # kart -> (request, wall time sent)
        self._stop_status: str | None = None
        self._stop = asyncio.Event()
        self._close = asyncio.Event()
        self._message_cache: tuple[int, str] | None = None
        self.task: asyncio.Task[None] | None = None
        self.on_closed: Callable[[RaceSession], None] | None = None
        self.other_starts: Callable[[], list[float]] = list  # schedule starts of the other running races

    def _make_driver(self, index: int, entry: KartEntry, token: str | None) -> KartDriver:
        if entry.controller == HUMAN:
            return KartDriver(index, entry.name, HUMAN, None, token)
        try:
            controller = self._catalogue[entry.controller].factory()
        except Exception as exc:
            driver = KartDriver(index, entry.name, entry.controller, None, None)
            driver.exceptions += 1
            driver.disabled = True
            driver.record_error(f"construction raised {type(exc).__name__}: {exc}")
            return driver
        return KartDriver(index, entry.name, entry.controller, controller, None)

    # ------------------------------------------------------------------ control
    def start(self) -> None:
        """Start the race's task on the running event loop."""
        self.task = asyncio.get_running_loop().create_task(self._run(), name=f"race-{self.id}")

    @property
    def live(self) -> bool:
        """Whether the race has not ended yet."""
        return self.status in LIVE

    def stop(self, status: str = "stopped") -> bool:
        """End the race at the next tick with ``status`` (``stopped`` or ``aborted``); False if already over."""
        if not self.live or self._stop_status is not None:
            return False
        self._stop_status = status
        self._stop.set()
        return True

    def close(self) -> None:
        """End the race (as ``aborted`` if live) and drop it without lingering (server shutdown)."""
        self.stop("aborted")
        self._close.set()

    async def wait_status(self, statuses: Sequence[str]) -> None:
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

    # ------------------------------------------------------------------ views
    def telemetry_message(self) -> str | None:
        """The current frame as a telemetry JSON message (built once per frame for every subscriber)."""
        frame = self.frame
        if frame is None:
            return None
        if self._message_cache is None or self._message_cache[0] != id(frame):
            self._message_cache = (id(frame), json.dumps({"type": "frame", **frame_dict(frame)}))
        return self._message_cache[1]

    def replay_dict(self) -> dict[str, Any]:
        """The replay so far in the headless format (``controllers.race.Replay``) plus the race id and karts."""
        replay = Replay(self.config.track.name, DT, self._poses[: self._recorded].tolist(), list(self._plans))
        return {"race_id": self.id, "karts": self.kart_list(), **vars(replay)}

    def kart_list(self) -> list[dict[str, Any]]:
        """``[{index, name, controller}]``."""
        return [{"index": d.index, "name": d.name, "controller": d.controller_name} for d in self.drivers]

    # ------------------------------------------------------------------ the race task
    async def _run(self) -> None:
        try:
            await self._prepare()
            if self._stop_status is None:
                await self._wait_for_humans()
            if self._stop_status is None:
                await self._race()
            await self._end(self._stop_status or "finished")
        except asyncio.CancelledError:
            await self._end("aborted")
            raise
        except Exception as exc:
            log.exception("race %s failed", self.id)
            self.error = f"{type(exc).__name__}: {exc}"
            await self._end("aborted")
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
        # preallocated up to the time limit: a growing list of lists would give the garbage collector work
        self._poses = np.zeros((int(world.rule_vector[st.RP_TIME_LIMIT_STEPS]) + 1, len(self.drivers), 6))
        n = len(self.drivers)
        limit = world.lane_change_limit
        contexts = {
            d.index: RaceContext(config.track, params.kart, d.index, n, limit, config.seed * 1000 + d.index)
            for d in self.drivers
            if not d.human
        }
        ai = [d for d in self.drivers if not d.human and not d.disabled]
        for d in ai:
            if self._hosts is not None:
                factory = self._catalogue[d.controller_name].factory
                self._workers[d.index] = self._hosts.attach(d, factory, contexts[d.index])
            else:
                self._workers[d.index] = DriverThread(d, contexts[d.index], f"race-{self.id}-kart{d.index}")
        opening = [self._open_planner(d, contexts[d.index]) for d in ai if d.hierarchical]
        await asyncio.gather(self._open_scene(), *opening)
        while any(w.resetting for w in self._workers.values()) and self._stop_status is None:
            self._check_hang()
            await asyncio.sleep(HANG_POLL_S)
        self._publish()

    def _build_world(self, params: SimParams) -> World:
        config = self.config
        world = World(config.track, 1, len(self.drivers), params, laps=config.laps)
        world.reset(start_lanes=config.start_lanes)
        return world

    async def _open_planner(self, driver: KartDriver, context: RaceContext) -> None:
        setup = PlannerSetup(self._catalogue[driver.controller_name].factory, context)
        try:
            await asyncio.wait_for(self._pool.open(self._plan_key(driver), setup), self.settings.controller_reset_s)
        except Exception as exc:
            driver.planner_faults += 1
            driver.record_error(f"planner setup failed: {type(exc).__name__}: {exc}")

    async def _open_scene(self) -> None:
        if self._scene_factory is None:
            return
        label = f"{self.config.track_name} · race {self.id}"
        karts = [(d.name, d.controller_name) for d in self.drivers]
        try:
            self.scene = await asyncio.to_thread(self._scene_factory, self.config.track, karts, label)
        except Exception:
            log.exception("race %s: the 3D view could not start; racing without it", self.id)

    async def _wait_for_humans(self) -> None:
        humans = [d for d in self.drivers if d.human]
        if not humans:
            return
        await self._set_status("waiting")
        give_up = time.monotonic() + self.settings.human_wait_s
        while not all(d.ever_connected for d in humans) and time.monotonic() < give_up:
            try:
                await asyncio.wait_for(self._stop.wait(), 0.05)
                return
            except TimeoutError:
                pass

    async def _race(self) -> None:
        assert self.world is not None
        await self._set_status("running")
        loop = asyncio.get_running_loop()
        period = DT / self.settings.speedup
        self._submit(observe(self.world, 0))  # the first inputs come from the grid
        t0 = spread_start(loop.time() + period, period, self.other_starts())
        schedule = self.schedule = TickSchedule(t0, period)
        while True:
            await sleep_until(schedule.deadline)
            schedule.started(loop.time())
            self._tick()
            schedule.finished(loop.time())
            if self.world.done[0] or self._stop_status is not None:
                return

    # ------------------------------------------------------------------ one tick
    def _tick(self) -> None:
        world = self.world
        assert world is not None
        self._check_hang()
        self._collect_plans()
        step = int(world.steps[0])
        speeds = world.fstate[0, :, st.F_SPEED]
        now = time.monotonic()
        for d in self.drivers:
            if d.human:
                self._human_input(d, now, float(speeds[d.index]))
            else:
                self._ai_input(d, step, float(speeds[d.index]))
            self._actions[0, d.index] = (d.steer, d.throttle)
        world.step(self._actions)
        observations = observe(world, 0)
        self._submit(observations)
        self._request_plans(observations)
        if self._recorded < len(self._poses):
            pose = self._poses[self._recorded]
            pose[:, :4] = world.fstate[0][:, POSE_COLUMNS]
            pose[:, 4:] = self._actions[0]
            self._recorded += 1
        self._publish()

    def _human_input(self, d: KartDriver, now: float, speed: float) -> None:
        received = d.input
        if received is None or d.input_at is None or now - d.input_at > self.settings.drive_timeout_s:
            d.throttle = brake_throttle(speed)  # a silent driver brakes, holding the steer
            d.braking = True
            return
        d.steer, d.throttle, d.applied_seq = received
        d.braking = False

    def _ai_input(self, d: KartDriver, step: int, speed: float) -> None:
        worker = self._workers.get(d.index)
        out = worker.latest if worker is not None else None
        if out is not None and out[0] > d.fresh_step:
            d.fresh_step, d.steer, d.throttle = out
        if d.submitted_step > d.fresh_step:
            d.missed += 1
        hold_ticks = max(round(self.settings.controller_hold_s / DT), 2 * d.every)
        if d.disabled or not d.ready or step - d.fresh_step > hold_ticks:
            d.throttle = brake_throttle(speed)
            d.braking = True
        else:
            d.braking = False

    def _submit(self, observations: Sequence[Observation]) -> None:
        assert self.world is not None
        step = int(self.world.steps[0])
        for k, worker in self._workers.items():
            d = self.drivers[k]
            if d.ready and not d.disabled and step % d.every == 0 and not observations[k].me.finished:
                d.submitted_step = step
                worker.submit(step, observations[k])

    def _check_hang(self) -> None:
        if self._hosts is not None:
            self._hosts.revive()
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
            log.warning("race %s kart %d (%s): %s; the kart brakes", self.id, k, d.controller_name, d.last_error)
            worker.retire()
            del self._workers[k]

    # ------------------------------------------------------------------ plans
    def _plan_key(self, d: KartDriver) -> str:
        return f"{self.id}/{d.index}"

    def _request_plans(self, observations: Sequence[Observation]) -> None:
        now = time.monotonic()
        for d in self.drivers:
            controller = d.controller
            if not isinstance(controller, HierarchicalController) or d.disabled:
                continue
            pending = self._plan_tasks.get(d.index)
            if pending is not None:
                if now - pending[1] > self.settings.plan_timeout_s:
                    pending[0].cancel()
                    del self._plan_tasks[d.index]
                    d.planner_faults += 1
                    d.last_error = f"no plan within {self.settings.plan_timeout_s:g} s"
                    self._pool.replace_if_stuck(self._plan_key(d), self.settings.plan_timeout_s)
                continue
            observation = observations[d.index]
            if observation.me.finished or not controller.wants_plan(observation.time):
                continue
            controller.mark_plan_requested(observation.time)
            task = asyncio.get_running_loop().create_task(self._pool.plan(self._plan_key(d), observation))
            self._plan_tasks[d.index] = (task, now)

    def _collect_plans(self) -> None:
        for kart, (task, _sent) in list(self._plan_tasks.items()):
            if not task.done():
                continue
            del self._plan_tasks[kart]
            d = self.drivers[kart]
            if task.cancelled():
                continue
            exc = task.exception()
            if exc is not None:
                d.planner_faults += 1
                d.last_error = f"planner raised {type(exc).__name__}: {exc}"
                continue
            self._deliver(d, task.result())

    def _deliver(self, d: KartDriver, plan: Plan) -> None:
        assert isinstance(d.controller, HierarchicalController) and self.world is not None
        d.controller.deliver(plan)
        worker = self._workers.get(d.index)
        if worker is not None:
            worker.deliver(plan)
        for waypoint in plan.ego_waypoints:  # the referee's delta_r / delta_v targets, as in headless races
            self.world.set_target(0, d.index, waypoint.checkpoint, waypoint.lane, waypoint.speed)
        d.waypoints = tuple(w.position for w in plan.ego_waypoints)
        d.predicted = tuple(w.position for ws in plan.opponent_waypoints().values() for w in ws)
        self.plans_version += 1
        self._plans.append({"step": int(self.world.steps[0]), "kart": d.index, "plan": asdict(plan)})

    # ------------------------------------------------------------------ frames
    def _publish(self) -> None:
        if self.world is None:
            self.updates.publish()
            return
        self.frame = frame = self._build_frame()
        if self.scene is not None:
            try:
                self.scene.update(frame)
            except Exception:
                log.exception("race %s: the 3D view failed; racing without it", self.id)
                scene, self.scene = self.scene, None
                asyncio.get_running_loop().create_task(asyncio.to_thread(scene.close))
        self.updates.publish()

    def _build_frame(self) -> RaceFrame:
        world = self.world
        assert world is not None
        n_cp = self.config.track.n_checkpoints
        laps = self.config.laps
        fs = world.fstate[0].tolist()
        ints = world.istate[0].tolist()
        position = [0] * len(self.drivers)
        for place, k in enumerate(world.standings(0)):
            position[k] = place + 1
        karts = []
        for d in self.drivers:
            f, i = fs[d.index], ints[d.index]
            finished = bool(i[st.I_FINISHED])
            karts.append(
                KartFrame(
                    index=d.index,
                    name=d.name,
                    controller=d.controller_name,
                    x=f[st.F_X],
                    y=f[st.F_Y],
                    heading=f[st.F_HEADING],
                    speed=f[st.F_SPEED],
                    steer=f[st.F_STEER],
                    throttle=f[st.F_THROTTLE],
                    lap=min(max(i[st.I_CP_PASSED], 0) // n_cp + 1, laps),
                    position=position[d.index],
                    checkpoints_passed=i[st.I_CP_PASSED],
                    lane=i[st.I_LANE],
                    collisions_at_fault=i[st.I_FAULTS],
                    illegal_lane_changes=i[st.I_ILLEGAL],
                    wall_hits=i[st.I_WALL_HITS],
                    finished=finished,
                    finish_time=f[st.F_FINISH_TIME] if finished else None,
                    controller_faults=d.faults,
                    waypoints=d.waypoints,
                    predicted=d.predicted,
                )
            )
        step = int(world.steps[0])
        return RaceFrame(
            race_id=self.id,
            track=self.config.track_name,
            time=step * DT,
            step=step,
            laps=laps,
            status=self.status,
            karts=tuple(karts),
            plans_version=self.plans_version,
        )

    # ------------------------------------------------------------------ the end
    async def _set_status(self, status: str) -> None:
        self.status = status
        self._publish()
        await asyncio.to_thread(self._db.set_status, self.id, status)

    def _result_dict(self, status: str) -> dict[str, Any] | None:
        world = self.world
        if world is None:
            return None
        result = world.result(0)
        karts = []
        for kr in result.karts:
            d = self.drivers[kr.kart]
            karts.append(
                {
                    "index": kr.kart,
                    "name": d.name,
                    "controller": d.controller_name,
                    "position": kr.position,
                    "finished": kr.finished,
                    "finish_time": kr.finish_time,
                    "laps": kr.laps_completed,
                    "checkpoints_passed": kr.checkpoints_passed,
                    "winner": result.winner == kr.kart,
                    "collisions_at_fault": kr.collisions_at_fault,
                    "illegal_lane_changes": kr.illegal_lane_changes,
                    "safety_score": kr.safety_score,
                    "wall_hits": kr.wall_hits,
                    "contacts": kr.contacts,
                    "buffer_violations": kr.buffer_violations,
                    "delta_r": kr.delta_r,
                    "delta_v": kr.delta_v,
                    "controller_faults": d.faults,
                    "exceptions": d.exceptions,
                    "hangs": d.hangs,
                    "missed_deadlines": d.missed,
                    "planner_faults": d.planner_faults,
                    "plans_applied": d.controller.plans_applied
                    if isinstance(d.controller, HierarchicalController)
                    else 0,
                    "disabled": d.disabled,
                    "last_error": d.last_error,
                }
            )
        return {
            "race_id": self.id,
            "status": status,
            "track": self.config.track_name,
            "laps": self.config.laps,
            "duration": result.duration,
            "winner": result.winner,
            "karts": karts,
        }

    def tick_stats(self) -> dict[str, Any] | None:
        """Tick timing (see :class:`server.ticks.TickSummary`), or ``None`` before the first tick."""
        return asdict(self.schedule.summary()) if self.schedule is not None else None

    async def _end(self, status: str) -> None:
        if not self.live:
            return
        result = self._result_dict(status)
        try:
            if result is None:
                await asyncio.to_thread(self._db.set_status, self.id, status)
            else:
                await asyncio.to_thread(self._store, result, self.tick_stats())
        except Exception:
            log.exception("race %s: could not store the result", self.id)
        # only now: whoever sees the race over finds its result and replay stored
        self.result = result
        self.status = status
        self._publish()

    def _store(self, result: dict[str, Any], tick_stats: dict[str, Any] | None) -> None:
        self._db.finish(self.id, result["status"], result["duration"], result, tick_stats or {}, self.replay_dict())

    def _release(self) -> None:
        for worker in self._workers.values():
            worker.retire()
        self._workers.clear()
        for task, _sent in self._plan_tasks.values():
            task.cancel()
        self._plan_tasks.clear()
        keys = tuple(self._plan_key(d) for d in self.drivers if d.hierarchical)
        if keys:
            self._pool.close(keys)

    async def _close_scene(self) -> None:
        scene, self.scene = self.scene, None
        if scene is not None:
            try:
                await asyncio.to_thread(scene.close)
            except Exception:
                log.exception("race %s: closing the 3D view failed", self.id)
