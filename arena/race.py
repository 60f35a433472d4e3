"""One race of a tournament: what to run (:class:`RaceJob`, picklable, sent to a worker process or a Ray task),
what comes back (:class:`FinishedRace`) and its figures for the statistics (:func:`race_figures`).

The headless race itself is :func:`controllers.race.run_race`, re-exported here with :class:`RaceSpec` and
:class:`RaceOutcome`, so code about running many races imports from :mod:`arena` only.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from arena.manifest import Manifest, race_manifest
from arena.records import CHECKPOINT, PER_STEP, KartFigures, RaceFigures
from controllers.base import Action, Controller, PlanningDriver, RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.plan import Plan
from controllers.race import RaceOutcome, RaceSpec, batch_key, load_any_track, run_race, run_races
from controllers.registry import make_agent, validate_parameters
from controllers.tactical.game import GameParams
from controllers.tactical.high_level import MCTSPlanner
from sim_core.observation import Observation
from sim_core.world import KartResult, RaceResult

__all__ = ["FinishedRace", "RaceJob", "RaceOutcome", "RaceSpec", "race_figures", "run_job", "run_jobs", "run_race"]


@dataclass(frozen=True)
class RaceJob:
    """One scheduled race: its place in the tournament, track, agents (kart 0 first), seed and start lanes."""

    index: int
    track: str
    agents: tuple[str, ...]
    seed: int
    start_lanes: tuple[int, ...]
    laps: int | None = None  # None: the track's
    time_limit: float | None = None  # [s] None: the rules' limit
    kart_preset: str = "paper"
    plan_latency: float = 0.1  # [s]
    background_planners: tuple[str, ...] = ()  # agents given an MCTS planner in the background (Δr, Δv only)
    conditions: str = "paper"  # the race conditions' set (:mod:`sim_core.conditions`), drawn from the seed
    teams: tuple[str, ...] | None = None  # each kart's team (None: every kart for itself)

    def spec(self) -> RaceSpec:
        """The headless race to run."""
        return RaceSpec(
            track=self.track,
            controllers=self.agents,
            laps=self.laps,
            seed=self.seed,
            start_lanes=self.start_lanes,
            kart_preset=self.kart_preset,
            plan_latency=self.plan_latency,
            time_limit=self.time_limit,
            conditions=self.conditions,
            teams=self.teams,
        )


@dataclass(frozen=True)
class FinishedRace:
    """A race run to its end: the referee's result, the laps raced, the job's wall time (building the drivers
    included) and the replay (a JSON dict)."""

    job: RaceJob
    result: RaceResult
    laps: int
    wall_seconds: float
    replay: dict[str, Any] | None
    lap_times: tuple[tuple[float, ...], ...] = ()  # [s] each kart's completed laps, by kart index
    # what it measured, resolved in the process that raced it (which may load newer code than the runner's)
    manifest: Manifest | None = None

    def figures(self, race_id: str | None = None) -> RaceFigures:
        """The race's figures for the statistics."""
        return race_figures(self.job, self.result.karts, self.result.duration, race_id)


class PlanIgnoringTracker:
    """A whole driver in the tracker's place: it drives as it always does and never sees the plan."""

    def __init__(self, driver: Controller) -> None:
        self.driver = driver

    def reset(self, context: RaceContext) -> None:
        """Reset the driver."""
        self.driver.reset(context)

    def act(self, observation: Observation, plan: Plan | None) -> Action:
        """The driver's own inputs (``plan`` is ignored)."""
        return self.driver.act(observation)


BACKGROUND_PLANNER = "mcts-rl"  # whose default search settings the background planner takes


def background_planner_settings() -> dict[str, Any]:
    """The background planner's settings (:func:`with_background_planner`), as manifests record them."""
    settings = validate_parameters(BACKGROUND_PLANNER, {})
    return {
        "settings_of": BACKGROUND_PLANNER,
        "iterations": settings.iterations,
        "horizon": settings.horizon,
        "planner_rate_hz": settings.planner_rate_hz,
    }


def with_background_planner(agent: str) -> Controller:
    """``agent`` driving unchanged while the MCTS tactical planner (``mcts-rl``'s settings) plans for its kart in the
    background, so the referee measures its Δr and Δv against the plans, as the paper did for E2E. An agent that
    plans already is returned as it is."""
    driver = make_agent(agent)
    if isinstance(driver, PlanningDriver):
        return driver
    settings = validate_parameters(BACKGROUND_PLANNER, {})
    game = GameParams(horizon=settings.horizon)
    planner = MCTSPlanner(iterations=settings.iterations, rate_hz=settings.planner_rate_hz, params=game)
    return HierarchicalController(agent, planner, PlanIgnoringTracker(driver), rate_hz=driver.rate_hz)


def job_drivers(job: RaceJob) -> list[Controller]:
    """The drivers of ``job``: registered controllers, those in ``background_planners`` with a background planner."""
    return [with_background_planner(a) if a in job.background_planners else make_agent(a) for a in job.agents]


def run_job(job: RaceJob, record: bool = True) -> FinishedRace:
    """Run ``job`` alone (in whatever process calls it); ``record``: keep the replay."""
    started = time.perf_counter()
    outcome = run_race(job.spec(), record=record, drivers=job_drivers(job))
    return _finished(job, outcome, time.perf_counter() - started)


def run_jobs(jobs: Sequence[RaceJob], record: bool = True) -> list[FinishedRace]:
    """Run ``jobs`` (in whatever process calls it) through the batched runner
    (:func:`controllers.race.run_races`): jobs that share a :func:`~controllers.race.batch_key` advance together.
    Each race's result is the one :func:`run_job` gives it; its ``wall_seconds`` is its batch's wall time shared
    out evenly among the batch's races."""
    groups: dict[object, list[RaceJob]] = {}
    for job in jobs:
        groups.setdefault(batch_key(job.spec()), []).append(job)
    finished: dict[int, FinishedRace] = {}
    for group in groups.values():
        started = time.perf_counter()
        outcomes = run_races([job.spec() for job in group], record=record, drivers=[job_drivers(j) for j in group])
        share = (time.perf_counter() - started) / len(group)
        for job, outcome in zip(group, outcomes, strict=True):
            finished[job.index] = _finished(job, outcome, share)
    return [finished[job.index] for job in jobs]


def _finished(job: RaceJob, outcome: RaceOutcome, wall: float) -> FinishedRace:
    background = background_planner_settings() if job.background_planners else None
    manifest = race_manifest(job.spec(), job.background_planners, background)
    laps = job.laps if job.laps is not None else load_any_track(job.track).laps
    replay = outcome.replay.as_dict() if outcome.replay is not None else None
    return FinishedRace(job, outcome.result, laps, wall, replay, outcome.lap_times, manifest)


def kart_figures(agent: str, kart: KartResult) -> KartFigures:
    """One kart's figures from the referee's result: both lane-change counts, the safety score under the per-step
    rule (the referee's default, eqs. (10)-(11) as they happen)."""
    return KartFigures(
        agent=agent,
        finished=kart.finished,
        total_time=kart.finish_time,
        collisions_at_fault=kart.collisions_at_fault,
        illegal_lane_changes={
            PER_STEP: kart.illegal_lane_changes_per_step,
            CHECKPOINT: kart.illegal_lane_changes_checkpoint,
        },
        safety_rule=PER_STEP,
        passes=kart.passes,
        delta_r=kart.delta_r,
        delta_v=kart.delta_v,
        contacts_with=kart.contacts_with or None,
        passes_of=kart.passes_of or None,
    )


def race_figures(
    job: RaceJob, karts: Sequence[KartResult], duration: float | None = None, race_id: str | None = None
) -> RaceFigures:
    """A race's figures from the referee's per-kart results (indexed by kart, as ``job.agents``)."""
    ordered = sorted(karts, key=lambda k: k.kart)
    return RaceFigures(
        track=job.track,
        karts=tuple(kart_figures(job.agents[k.kart], k) for k in ordered),
        index=job.index,
        seed=job.seed,
        start_lanes=job.start_lanes,
        conditions=job.conditions,
        duration=duration,
        race_id=race_id,
        teams=job.teams,
    )
