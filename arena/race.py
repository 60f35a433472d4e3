"""One race of a tournament: what to run (:class:`RaceJob`, picklable, sent to a worker process or a Ray task),
what comes back (:class:`FinishedRace`) and its figures for the statistics (:func:`race_figures`).

The headless race itself is :func:`controllers.race.run_race`, re-exported here with :class:`RaceSpec` and
:class:`RaceOutcome`, so code about running many races imports from :mod:`arena` only.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

from arena.records import CHECKPOINT, PER_STEP, KartFigures, RaceFigures
from controllers.race import RaceOutcome, RaceSpec, load_any_track, run_race
from sim_core.world import KartResult, RaceResult

__all__ = ["FinishedRace", "RaceJob", "RaceOutcome", "RaceSpec", "race_figures", "run_job", "run_race"]


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

    def figures(self, race_id: str | None = None) -> RaceFigures:
        """The race's figures for the statistics."""
        return race_figures(self.job, self.result.karts, self.result.duration, race_id)


def run_job(job: RaceJob, record: bool = True) -> FinishedRace:
    """Run ``job`` (in whatever process calls it); ``record``: keep the replay."""
    started = time.perf_counter()
    outcome = run_race(job.spec(), record=record)
    laps = job.laps if job.laps is not None else load_any_track(job.track).laps
    replay = asdict(outcome.replay) if outcome.replay is not None else None
    return FinishedRace(job, outcome.result, laps, time.perf_counter() - started, replay)


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
        duration=duration,
        race_id=race_id,
    )
