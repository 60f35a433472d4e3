"""Headless races between registered controllers, faster than real time and deterministic for a seed: one race
(:func:`run_race`) or many advancing together in one batched world (:func:`run_races`)."""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, replace
from functools import cache
from typing import Any, Protocol, cast, runtime_checkable

import numpy as np

from controllers.base import Action, Controller, PlanningDriver, RaceContext, team_numbers
from controllers.registry import agent_pace, make_agent
from controllers.replay import Replay, ReplayRecorder, apply_plan_targets
from sim_core import state as st
from sim_core.conditions import ConditionSet, Imprecision, RaceConditions, condition_set
from sim_core.laps import LapTimer
from sim_core.observation import Observation, observe
from sim_core.params import DT, SimParams, kart_preset
from sim_core.track import Track
from sim_core.track_io import get_track, load_track
from sim_core.world import RaceResult, World


@dataclass(frozen=True)
class Placement:
    """Where a kart starts instead of its grid slot: at centre-line progress ``progress`` [m] (on its first lap),
    in ``lane``, rolling at ``speed`` [m/s] along the track (a scenario's start, :mod:`arena.scenarios`)."""

    progress: float
    lane: int
    speed: float = 0.0


@dataclass(frozen=True)
class RaceSpec:
    """A headless race: which track, which drivers (by registered name), laps, seed, starting lanes and the
    conditions it is raced under (a named :class:`~sim_core.conditions.ConditionSet`, drawn from the seed)."""

    track: str = "oval"
    controllers: tuple[str, ...] = ("mcts-lqng", "fixed-lqng")
    laps: int | None = None
    seed: int = 0
    start_lanes: tuple[int, ...] | None = None
    kart_preset: str = "paper"
    plan_latency: float = 0.1  # [s] simulated delay between requesting and applying a high-level plan
    time_limit: float | None = None  # [s] end the race then (None: the rules' limit)
    # a named set of sim_core.conditions.CONDITION_SETS ("paper": the original's, "varied"), or a set of one's own
    conditions: str | ConditionSet = "paper"
    placements: tuple[Placement, ...] | None = None  # one per kart: placed karts instead of the grid
    teams: tuple[str, ...] | None = None  # one per kart: its team (None: every kart for itself)

    def __post_init__(self) -> None:
        self.condition_set()  # a clear KeyError for an unknown set
        if self.placements is not None and len(self.placements) != len(self.controllers):
            raise ValueError(f"need one placement for each of the {len(self.controllers)} karts")
        if self.teams is not None and len(self.teams) != len(self.controllers):
            raise ValueError(f"need one team for each of the {len(self.controllers)} karts")

    def condition_set(self) -> ConditionSet:
        """The set this race's conditions are drawn from."""
        return self.conditions if isinstance(self.conditions, ConditionSet) else condition_set(self.conditions)

    def drawn(self) -> RaceConditions:
        """This race's conditions: a function of the seed, the number of karts and the start lanes alone, so two
        series with the same seeds and different drivers meet the same conditions (a paired comparison)."""
        return self.condition_set().draw(self.seed, len(self.controllers), self.start_lanes)

    def kart_paces(self, conditions: RaceConditions) -> tuple[float, ...]:
        """Each kart's pace: its agent's handicap (``NAME@PACE``; 1 without) times the pace ``conditions`` drew."""
        return tuple(agent_pace(a) * p for a, p in zip(self.controllers, conditions.paces, strict=True))


@dataclass(frozen=True)
class RaceOutcome:
    """The referee's result, wall time and the optional replay."""

    spec: RaceSpec
    result: RaceResult
    wall_seconds: float
    replay: Replay | None
    lap_times: tuple[tuple[float, ...], ...] = ()  # [s] each kart's completed laps, by kart index
    conditions: RaceConditions | None = None  # as drawn (:meth:`RaceSpec.drawn`)

    @property
    def start_delays(self) -> tuple[float, ...]:
        """[s] each kart's launch delay."""
        return self.conditions.launch_delays if self.conditions is not None else ()


def load_any_track(name: str) -> Track:
    """A built-in track by name, or a track JSON by path."""
    if name.endswith(".json") or "/" in name:
        return load_track(name)
    return get_track(name)


StepHook = Callable[[World, Sequence[Controller], int], None]
RacesHook = Callable[[World, int, Sequence[Controller], int], None]  # (world, race, drivers, step)


def run_race(
    spec: RaceSpec,
    *,
    record: bool = False,
    on_step: StepHook | None = None,
    drivers: Sequence[Controller] | None = None,
) -> RaceOutcome:
    """Race ``spec`` to the end (everyone finished or the time limit) and return the result.

    ``on_step(world, drivers, step)`` is called after every simulation step (measurements, e.g.
    :class:`controllers.race_metrics.RaceMetrics`). ``drivers`` (one per kart, new) replaces building
    ``spec.controllers`` from the registry (a composed driver, e.g. a tournament's E2E with a background
    planner for its Δr / Δv). A batch of one of :func:`run_races`."""
    hook: RacesHook | None = None
    if on_step is not None:
        step_hook = on_step

        def hook(world: World, _race: int, race_drivers: Sequence[Controller], step: int) -> None:
            step_hook(world, race_drivers, step)

    return run_races([spec], record=record, on_step=hook, drivers=None if drivers is None else [drivers])[0]


def batch_key(spec: RaceSpec) -> tuple[str, str, int | None, float | None, int]:
    """What races must share to advance in one :class:`~sim_core.world.World`: track, kart, laps, time limit and
    the number of karts (:func:`run_races`)."""
    return (spec.track, spec.kart_preset, spec.laps, spec.time_limit, len(spec.controllers))


def run_races(
    specs: Sequence[RaceSpec],
    *,
    record: bool = False,
    on_step: RacesHook | None = None,
    drivers: Sequence[Sequence[Controller]] | None = None,
) -> list[RaceOutcome]:
    """Race ``specs`` together, each to its end, in one batched :class:`~sim_core.world.World`: every step,
    each race's drivers that are due decide (:func:`decide`: drivers with a batch path, :class:`BatchDriver`,
    together), then the world steps every unfinished race at once. A finished race leaves the batch; the others
    go on. Each race's result is the one :func:`run_race` gives it alone: races share no state, and a batch path
    must return what its drivers' own ``act`` would.

    The specs must share :func:`batch_key` (``ValueError`` otherwise). ``drivers``: one list per race, as
    :func:`run_race`'s. ``on_step(world, race, drivers, step)`` is called for each unfinished race after every
    step. A race's ``wall_seconds`` is the time from the batch's start to its end."""
    if not specs:
        return []
    keys = {batch_key(spec) for spec in specs}
    if len(keys) > 1:
        raise ValueError(f"races of one batch share track, kart preset, laps, time limit and karts; got {keys}")
    first = specs[0]
    track = load_any_track(first.track)
    params = SimParams(kart=kart_preset(first.kart_preset))
    if first.time_limit is not None:
        params = replace(params, rules=replace(params.rules, time_limit=first.time_limit))
    if drivers is not None and len(drivers) != len(specs):
        raise ValueError(f"{len(drivers)} driver lists for {len(specs)} races")
    world = World(track, len(specs), len(first.controllers), params, laps=first.laps)
    races = [
        _Race.start(b, spec, world, params, None if drivers is None else drivers[b], record)
        for b, spec in enumerate(specs)
    ]
    actions = np.zeros((len(specs), world.n_karts, 2))
    t0 = time.perf_counter()
    step = 0
    running = races
    while running:
        due = [decision for race in running for decision in race.due_decisions(world, step)]
        decided = decide([race.drivers[k] for race, k, _ in due], [o for _, _, o in due])
        for (race, k, _), action in zip(due, decided, strict=True):
            actions[race.index, k] = (action.steer, action.throttle)
            race.after_act(world, k, step)
        for race in running:
            race.hold_waiting(actions, step)
        applied = actions
        if any(race.imprecision is not None for race in running):  # the drivers' commands stay as they decided
            applied = actions.copy()
            for race in running:
                applied[race.index] = race.with_imprecision(world, actions[race.index], step)
        world.step(applied)
        done = world.done
        for race in running:
            race.after_step(world, applied, step, on_step)
            if done[race.index]:
                race.wall = time.perf_counter() - t0
        running = [race for race in running if not done[race.index]]
        step += 1
    return [race.outcome(world) for race in races]


@runtime_checkable
class BatchDriver(Protocol):
    """A driver that can decide together with others: :func:`decide` groups the drivers due at a step by
    :meth:`batch_key` and asks the first of each group to :meth:`act_batch` for all of them. The actions must be
    the ones each driver's own ``act`` gives (a driver without this path simply acts alone)."""

    def batch_key(self) -> Hashable:
        """Drivers with equal keys (and of one class) decide in one :meth:`act_batch` call."""

    def act_batch(self, drivers: Sequence[Any], observations: Sequence[Observation]) -> list[Action]:
        """Each of ``drivers``' (this one's group, itself included) action for its observation."""


def decide(drivers: Sequence[Controller], observations: Sequence[Observation]) -> list[Action]:
    """Every driver's action for its observation: drivers with a batch path (:class:`BatchDriver`) grouped by
    class and key, one call per group; the others one ``act`` each, in order."""
    actions: list[Action | None] = [None] * len(drivers)
    groups: dict[tuple[type, Hashable], list[int]] = {}
    for i, driver in enumerate(drivers):
        if _has_batch_path(type(driver)):
            groups.setdefault((type(driver), cast(BatchDriver, driver).batch_key()), []).append(i)
        else:
            actions[i] = driver.act(observations[i])
    for members in groups.values():
        lead = cast(BatchDriver, drivers[members[0]])
        batch = lead.act_batch([drivers[i] for i in members], [observations[i] for i in members])
        for i, action in zip(members, batch, strict=True):
            actions[i] = action
    return [action for action in actions if action is not None]


@cache
def _has_batch_path(kind: type) -> bool:
    """Whether drivers of class ``kind`` are :class:`BatchDriver` s, checked once per class (a runtime Protocol
    check costs tens of microseconds: every step it was a tenth of a race's time)."""
    return all(callable(getattr(kind, name, None)) for name in ("batch_key", "act_batch"))


@dataclass
class _Race:
    """One race of a batch: its spec, drivers and what is kept of it as it runs."""

    index: int
    spec: RaceSpec
    drivers: Sequence[Controller]
    planning: list[PlanningDriver | None]  # each driver's planning capability, looked up once
    hold: list[int]  # steps between a driver's decisions
    applied: list[int]  # plans applied so far, by kart
    conditions: RaceConditions
    imprecision: Imprecision | None  # the drivers' hands (None: commands applied as given)
    laps: LapTimer
    recorder: ReplayRecorder | None
    wall: float = 0.0

    @classmethod
    def start(
        cls,
        index: int,
        spec: RaceSpec,
        world: World,
        params: SimParams,
        drivers: Sequence[Controller] | None,
        record: bool,
    ) -> _Race:
        """Put race ``index`` on its grid and reset its drivers (built from the registry unless given)."""
        track, n = world.track, world.n_karts
        conditions = spec.drawn()
        world.reset(
            races=index,
            start_lanes=spec.start_lanes,
            wear=conditions.start_wear,
            start_offsets=conditions.start_offsets,
            paces=spec.kart_paces(conditions),
            finish=conditions.finish,
        )
        if spec.placements is not None:
            _place(world, index, spec.placements, conditions.start_wear)
            if conditions.finish == "equal_distance":
                world.finish_equal_distance(index)  # from the placed karts' spots
        if drivers is None:
            drivers = [make_agent(name) for name in spec.controllers]
        elif len(drivers) != n:
            raise ValueError(f"{len(drivers)} drivers for {n} karts")
        # a runtime Protocol check costs microseconds a call: once per race
        planning = [driver if isinstance(driver, PlanningDriver) else None for driver in drivers]
        for k, driver in enumerate(drivers):
            if (planner := planning[k]) is not None:
                planner.plan_latency = spec.plan_latency
            kart = world.kart_params(index, k)  # at its pace: a driver plans with the kart it has
            pace = float(world.paces[index, k])
            context = RaceContext(
                track, kart, k, n, world.lane_change_limit, spec.seed * 1000 + k, pace, team_numbers(spec.teams or ())
            )
            driver.reset(context)
        recorder = ReplayRecorder(track.name, n) if record else None
        if recorder is not None:
            recorder.allocate(round(params.rules.time_limit / DT) + 1)
        hold = [max(1, round(1.0 / (DT * d.rate_hz))) for d in drivers]
        return cls(
            index,
            spec,
            drivers,
            planning,
            hold,
            [0] * n,
            conditions,
            conditions.imprecision(),
            LapTimer(n, track.n_checkpoints),
            recorder,
        )

    def due_decisions(self, world: World, step: int) -> list[tuple[_Race, int, Observation]]:
        """(this race, kart, observation) of each unfinished kart whose driver decides at ``step``: every ``hold``
        steps, and on its first step after its launch delay."""
        finished = world.istate[self.index, :, st.I_FINISHED].tolist()
        karts = []
        for k, delay in enumerate(self.conditions.launch_delays):
            launching = step * DT >= delay and (step - 1) * DT < delay
            if (step % self.hold[k] == 0 or launching) and not finished[k]:
                karts.append(k)
        if not karts:  # no one decides (drivers at 25 Hz, every other step): nothing to observe
            return []
        observations = observe(world, self.index)
        return [(self, k, observations[k]) for k in karts]

    def hold_waiting(self, actions: np.ndarray, step: int) -> None:
        """Karts still within their launch delay stand (negative throttle reverses); their drivers plan all the
        same."""
        actions[self.index, ~self.conditions.launched(step)] = 0.0

    def with_imprecision(self, world: World, commands: np.ndarray, step: int) -> np.ndarray:
        """What the karts get of the drivers' ``commands`` (K, 2) this step: the commands, with the drivers'
        imprecision added for karts that have launched and not finished."""
        if self.imprecision is None:
            return commands
        racing = world.istate[self.index, :, st.I_FINISHED] == 0
        return self.imprecision.perturb(commands, self.conditions.launched(step) & racing)

    def after_step(self, world: World, actions: np.ndarray, step: int, on_step: RacesHook | None) -> None:
        """Note the step's laps, tell ``on_step`` and record the replay."""
        self.laps.observe(world, self.index)
        if on_step is not None:
            on_step(world, self.index, self.drivers, step)
        if self.recorder is not None:
            self.recorder.record(world, actions[self.index], self.index)

    def after_act(self, world: World, kart: int, step: int) -> None:
        """Show a plan the driver has just applied (in the world, for views and metrics, and in the replay)."""
        planner = self.planning[kart]
        if planner is not None and planner.plans_applied != self.applied[kart]:
            self.applied[kart] = planner.plans_applied
            _show_plan(world, self.index, kart, planner, self.recorder, step)

    def outcome(self, world: World) -> RaceOutcome:
        """The finished race's outcome."""
        replay = None if self.recorder is None else self.recorder.replay()
        return RaceOutcome(
            self.spec, world.result(self.index), self.wall, replay, self.laps.all_lap_times(), self.conditions
        )


def _place(world: World, race: int, placements: Sequence[Placement], wear: Sequence[float]) -> None:
    """Move race ``race``'s karts from the grid to ``placements`` (rolling along the track's direction)."""
    track = world.track
    for k, placed in enumerate(placements):
        section = int(np.searchsorted(track.checkpoint_s, placed.progress % track.length, side="right")) - 1
        d = float(track.lane_offsets(section % track.n_checkpoints)[placed.lane - 1])
        world.place_kart(race, k, s=placed.progress, d=d, speed=placed.speed, wear=wear[k])
    world.sense(race)


def _show_plan(
    world: World, race: int, kart: int, driver: PlanningDriver, recorder: ReplayRecorder | None, step: int
) -> None:
    """Put a newly applied plan's targets in the world (for views and metrics) and in the replay."""
    if driver.active_plan is None:
        return
    apply_plan_targets(world, race, kart, driver.active_plan)
    if recorder is not None:
        recorder.plan(step, kart, driver.active_plan)
