"""Headless races between registered controllers, faster than real time and deterministic for a seed."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from controllers.base import Controller, PlanningDriver, RaceContext
from controllers.registry import make_controller
from controllers.replay import Replay, ReplayRecorder, apply_plan_targets
from sim_core.laps import LapTimer
from sim_core.observation import observe
from sim_core.params import DT, SimParams, kart_preset
from sim_core.track import Track
from sim_core.track_io import get_track, load_track
from sim_core.world import RaceResult, World


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


@dataclass(frozen=True)
class RaceOutcome:
    """The referee's result, wall time and the optional replay."""

    spec: RaceSpec
    result: RaceResult
    wall_seconds: float
    replay: Replay | None
    lap_times: tuple[tuple[float, ...], ...] = ()  # [s] each kart's completed laps, by kart index


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
        drivers = [make_controller(name) for name in spec.controllers]
    elif len(drivers) != n:
        raise ValueError(f"{len(drivers)} drivers for {n} karts")
    for k, driver in enumerate(drivers):
        if isinstance(driver, PlanningDriver):
            driver.plan_latency = spec.plan_latency
        driver.reset(RaceContext(track, params.kart, k, n, world.lane_change_limit, spec.seed * 1000 + k))
    recorder = ReplayRecorder(track.name, n) if record else None
    if recorder is not None:
        recorder.allocate(round(params.rules.time_limit / DT) + 1)
    actions = np.zeros((1, n, 2))
    hold = [max(1, round(1.0 / (DT * d.rate_hz))) for d in drivers]
    applied = [0] * n
    laps = LapTimer(n, track.n_checkpoints)
    t0 = time.perf_counter()
    step = 0
    while not world.done[0]:
        observations = observe(world, 0)
        for k, driver in enumerate(drivers):
            if step % hold[k] == 0 and not observations[k].me.finished:
                action = driver.act(observations[k])
                actions[0, k] = (action.steer, action.throttle)
                if isinstance(driver, PlanningDriver) and driver.plans_applied != applied[k]:
                    applied[k] = driver.plans_applied
                    if driver.active_plan is not None:
                        apply_plan_targets(world, 0, k, driver.active_plan)
                        if recorder is not None:
                            recorder.plan(step, k, driver.active_plan)
        world.step(actions)
        laps.observe(world)
        if on_step is not None:
            on_step(world, drivers, step)
        if recorder is not None:
            recorder.record(world, actions[0])
        step += 1
    wall = time.perf_counter() - t0
    replay = None if recorder is None else recorder.replay()
    return RaceOutcome(spec, world.result(0), wall, replay, laps.all_lap_times())
