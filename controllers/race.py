"""Headless races between registered controllers, faster than real time and deterministic for a seed."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from controllers.base import Controller, PlanningDriver, RaceContext
from controllers.registry import make_agent
from controllers.replay import Replay, ReplayRecorder, apply_plan_targets
from sim_core.laps import LapTimer
from sim_core.observation import observe
from sim_core.params import DT, SimParams, kart_preset
from sim_core.track import Track
from sim_core.track_io import get_track, load_track
from sim_core.world import RaceResult, World

MAX_START_SPREAD = 2.0  # [s]
START_SPREAD_STREAM = 0x57A27  # keeps the launch delays' random stream apart from any other use of the seed


@dataclass(frozen=True)
class RaceSpec:
    """A headless race: which track, which drivers (by registered name), laps, seed and starting lanes."""

    track: str = "oval"
    controllers: tuple[str, ...] = ("mcts-lqng", "fixed-lqng")
    laps: int | None = None
    seed: int = 0
    start_lanes: tuple[int, ...] | None = None
    kart_preset: str = "paper"
    plan_latency: float = 0.1  # [s] simulated delay between requesting and applying a high-level plan
    time_limit: float | None = None  # [s] end the race then (None: the rules' limit)
    # [s] each kart launches after a delay drawn from the seed, uniform in [0, start_spread) (a driver's reaction
    # to the lights); 0: every kart launches at once, as in the paper's experiments
    start_spread: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.start_spread <= MAX_START_SPREAD:
            raise ValueError(f"start_spread must be in [0, {MAX_START_SPREAD}] s, got {self.start_spread}")

    def start_delays(self) -> tuple[float, ...]:
        """Each kart's launch delay [s]: a function of the seed and the number of karts alone, so two series with
        the same seeds and different drivers see the same starts (a paired comparison)."""
        n = len(self.controllers)
        if self.start_spread == 0.0:
            return (0.0,) * n
        rng = np.random.default_rng([self.seed, START_SPREAD_STREAM])
        return tuple(float(d) for d in rng.uniform(0.0, self.start_spread, n))


@dataclass(frozen=True)
class RaceOutcome:
    """The referee's result, wall time and the optional replay."""

    spec: RaceSpec
    result: RaceResult
    wall_seconds: float
    replay: Replay | None
    lap_times: tuple[tuple[float, ...], ...] = ()  # [s] each kart's completed laps, by kart index
    start_delays: tuple[float, ...] = ()  # [s] each kart's launch delay (:meth:`RaceSpec.start_delays`)


def load_any_track(name: str) -> Track:
    """A built-in track by name, or a track JSON by path."""
    if name.endswith(".json") or "/" in name:
        return load_track(name)
    return get_track(name)


StepHook = Callable[[World, Sequence[Controller], int], None]


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
    planner for its Δr / Δv)."""
    track = load_any_track(spec.track)
    params = SimParams(kart=kart_preset(spec.kart_preset))
    if spec.time_limit is not None:
        params = replace(params, rules=replace(params.rules, time_limit=spec.time_limit))
    n = len(spec.controllers)
    world = World(track, 1, n, params, laps=spec.laps)
    world.reset(start_lanes=spec.start_lanes)
    if drivers is None:
        drivers = [make_agent(name) for name in spec.controllers]
    elif len(drivers) != n:
        raise ValueError(f"{len(drivers)} drivers for {n} karts")
    # each driver's planning capability, looked up once (a runtime Protocol check costs microseconds a call)
    planning = [driver if isinstance(driver, PlanningDriver) else None for driver in drivers]
    for k, driver in enumerate(drivers):
        if (planner := planning[k]) is not None:
            planner.plan_latency = spec.plan_latency
        driver.reset(RaceContext(track, params.kart, k, n, world.lane_change_limit, spec.seed * 1000 + k))
    recorder = ReplayRecorder(track.name, n) if record else None
    if recorder is not None:
        recorder.allocate(round(params.rules.time_limit / DT) + 1)
    actions = np.zeros((1, n, 2))
    delays = spec.start_delays()
    hold = [max(1, round(1.0 / (DT * d.rate_hz))) for d in drivers]
    applied = [0] * n
    laps = LapTimer(n, track.n_checkpoints)
    t0 = time.perf_counter()
    step = 0
    while not world.done[0]:
        observations = observe(world, 0)
        for k, driver in enumerate(drivers):
            waiting = step * DT < delays[k]
            launching = not waiting and (step - 1) * DT < delays[k]  # the first step after its delay: decide now
            if (step % hold[k] == 0 or launching) and not observations[k].me.finished:
                action = driver.act(observations[k])
                actions[0, k] = (action.steer, action.throttle)
                if (planner := planning[k]) is not None and planner.plans_applied != applied[k]:
                    applied[k] = planner.plans_applied
                    _show_plan(world, k, planner, recorder, step)
            if waiting:
                actions[0, k] = (0.0, 0.0)  # standing (negative throttle reverses); its driver plans all the same
        world.step(actions)
        laps.observe(world)
        if on_step is not None:
            on_step(world, drivers, step)
        if recorder is not None:
            recorder.record(world, actions[0])
        step += 1
    wall = time.perf_counter() - t0
    replay = None if recorder is None else recorder.replay()
    return RaceOutcome(spec, world.result(0), wall, replay, laps.all_lap_times(), delays)


def _show_plan(world: World, kart: int, driver: PlanningDriver, recorder: ReplayRecorder | None, step: int) -> None:
    """Put a newly applied plan's targets in the world (for views and metrics) and in the replay."""
    if driver.active_plan is None:
        return
    apply_plan_targets(world, 0, kart, driver.active_plan)
    if recorder is not None:
        recorder.plan(step, kart, driver.active_plan)
