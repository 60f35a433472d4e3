"""Round-robin tournaments: every pair of agents, on every track, ``races_per_pair`` races each, start lanes
alternating between races (lanes 2 and 3, as the original), every race seeded from the tournament's seed.

Races run in chunks through the batched runner (:func:`arena.race.run_jobs`: a chunk's races of one track advance
together in one world), in worker processes (``backend="process"``, the default; ``forkserver`` start method, safe
with threads and numba), in this process (``"inline"``), or as tasks on a Ray cluster (``"ray"``,
``ray.init(address=...)``; the optional ``tournament`` extra), a chunk per task. Each finished race goes to a
:class:`RaceStore` as it finishes, in this process (one writer); a tournament run again with the same id and store
skips the races the store already holds, so an interrupted tournament resumes and ends with the same results as one
run straight through (every race depends on its job only).
"""

from __future__ import annotations

import logging
import math
import multiprocessing
import os
from collections.abc import Callable, Generator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict, dataclass, field
from itertools import combinations
from multiprocessing.context import BaseContext
from typing import Any, Literal, Protocol

import numpy as np

from arena.lifeline import die_with_parent
from arena.manifest import Manifest, build_manifest, describe_agent, time_limit_of
from arena.race import FinishedRace, RaceJob, background_planner_settings, run_jobs
from arena.records import RaceFigures
from controllers.race import batch_key, load_any_track
from controllers.registry import controller_names, parse_agent, validate_agent
from sim_core.conditions import CONDITION_SETS, condition_set

log = logging.getLogger(__name__)

Backend = Literal["process", "inline", "ray"]
BACKENDS: tuple[Backend, ...] = ("process", "inline", "ray")
START_LANES = (2, 3)  # the original's two start lanes, swapped every other race
TEAM_GRID_LANES = (2, 3, 1, 4)  # a team race's grid: one row, side by side (every kart the same distance to the flag)
# the slots of the first team in a team race, by the race's number in its pair and track: the three ways to split
# the row in two, each raced twice with the teams' slots swapped (a mirrored pair: the same seed, so the same
# conditions per slot)
TEAM_SPLITS = ((0, 1), (0, 2), (0, 3))
MAX_TEAM_SIZE = len(TEAM_GRID_LANES) // 2
BATCH_RACES = 8  # races per chunk at most: a chunk's races of one track advance together in one world


def race_seed(seed: int, track: int, race: int) -> int:
    """The seed of race ``race`` of every pair on the ``track``-th track of a tournament seeded ``seed``."""
    return int(np.random.SeedSequence([seed, track, race]).generate_state(1)[0] % 2**31)


@dataclass(frozen=True)
class TournamentSpec:
    """What a tournament races: agents (registered names, or names with parameters,
    :func:`controllers.registry.parse_agent`), tracks, races per pair and track, and the race settings."""

    agents: tuple[str, ...]
    tracks: tuple[str, ...] = ("oval", "complex")
    races_per_pair: int = 50
    seed: int = 0
    laps: int | None = None  # None: each track's
    time_limit: float | None = None  # [s] None: the rules' limit
    kart_preset: str = "paper"
    plan_latency: float = 0.1  # [s]
    # controllers without a planner given the MCTS planner in the background for their Δr / Δv (as the paper's E2E),
    # by name: an agent with parameters (``e2e:deterministic=false``) gets one too
    background_planners: tuple[str, ...] = ("e2e",)
    # the race conditions (sim_core.conditions.CONDITION_SETS), drawn from each race's seed: "varied" samples launch
    # reactions, start wear and the drivers' imprecision; "paper" is the original's experiment
    conditions: str = "varied"
    # karts per agent in each race: 1, the paper's head-to-head races; 2, team races (two karts of each agent, a
    # team, on a one-row grid in mirrored pairs of races: :meth:`jobs`)
    team_size: int = 1

    def problems(self) -> dict[str, str]:
        """What is wrong with this spec, by field (empty: nothing)."""
        found: dict[str, str] = {}
        known = controller_names()
        unknown, bad = [], []
        for agent in self.agents:
            try:
                validate_agent(agent)
            except KeyError:
                unknown.append(agent)
            except ValueError as error:  # a ParameterError too
                bad.append(str(error))
        if unknown:
            found["agents"] = f"unknown agents {unknown}; known: {known}"
        elif bad:
            found["agents"] = "; ".join(bad)
        elif len(set(self.agents)) != len(self.agents) or len(self.agents) < 2:
            found["agents"] = f"give two or more different agents, got {list(self.agents)}"
        bad_tracks = []
        for track in self.tracks:
            try:
                load_any_track(track)
            except (OSError, KeyError, ValueError):
                bad_tracks.append(track)
        if bad_tracks or not self.tracks:
            found["tracks"] = f"unknown tracks {bad_tracks}" if bad_tracks else "give one or more tracks"
        if self.races_per_pair < 1:
            found["races_per_pair"] = f"races_per_pair must be >= 1, got {self.races_per_pair}"
        if not 1 <= self.team_size <= MAX_TEAM_SIZE:
            found["team_size"] = (
                f"team_size must be 1 or up to {MAX_TEAM_SIZE} (a fair grid is one row of "
                f"{len(TEAM_GRID_LANES)}), got {self.team_size}"
            )
        elif self.team_size > 1 and self.races_per_pair % 2:
            found["races_per_pair"] = (
                f"team races come in mirrored pairs: give an even races_per_pair, not {self.races_per_pair}"
            )
        if self.conditions not in CONDITION_SETS:
            found["conditions"] = f"unknown conditions {self.conditions!r}; known: {sorted(CONDITION_SETS)}"
        return found

    def validate(self) -> TournamentSpec:
        """This spec, or ``ValueError`` naming every problem."""
        problems = self.problems()
        if problems:
            raise ValueError("; ".join(f"{name}: {message}" for name, message in problems.items()))
        return self

    def pairs(self) -> list[tuple[str, str]]:
        """Every pair of agents once, in the agents' order."""
        return list(combinations(self.agents, 2))

    def jobs(self) -> list[RaceJob]:
        """The schedule: per track, per pair, ``races_per_pair`` races. A paired design: race ``r`` of every pair on
        a track has the same seed (``numpy.random.SeedSequence([seed, track, r])``), so the same conditions.

        Head to head (``team_size`` 1), even races put the pair's first agent in lane 2, odd ones in lane 3. Team
        races (:meth:`team_race`) come in mirrored pairs: races ``2m`` and ``2m + 1`` have the seed of ``m`` and the
        teams' slots swapped, and the three ways to split the row take turns."""
        jobs: list[RaceJob] = []
        for t, track in enumerate(self.tracks):
            for a, b in self.pairs():
                for r in range(self.races_per_pair):
                    agents: tuple[str, ...]
                    lanes: tuple[int, ...]
                    teams: tuple[str, ...] | None
                    if self.team_size == 1:
                        seed = race_seed(self.seed, t, r)
                        agents, lanes, teams = (a, b), START_LANES if r % 2 == 0 else START_LANES[::-1], None
                    else:
                        seed = race_seed(self.seed, t, r // 2)
                        agents, lanes, teams = self.team_race(a, b, r)
                    job = RaceJob(
                        len(jobs),
                        track,
                        agents,
                        seed,
                        lanes,
                        self.laps,
                        self.time_limit,
                        self.kart_preset,
                        self.plan_latency,
                        tuple(agent for agent in (a, b) if parse_agent(agent)[0] in self.background_planners),
                        self.conditions,
                        teams,
                    )
                    jobs.append(job)
        return jobs

    def team_race(self, a: str, b: str, race: int) -> tuple[tuple[str, ...], tuple[int, ...], tuple[str, ...]]:
        """Race ``race`` of team ``a`` against team ``b``: each kart's agent and start lane, kart by grid slot (every
        slot in the one row of :data:`TEAM_GRID_LANES`), and each kart's team (its agent). Race ``2m`` gives ``a``
        the slots of split ``m mod 3`` (:data:`TEAM_SPLITS`), race ``2m + 1`` the other slots."""
        first: tuple[int, ...] = TEAM_SPLITS[(race // 2) % len(TEAM_SPLITS)]
        if race % 2:
            first = tuple(slot for slot in range(len(TEAM_GRID_LANES)) if slot not in first)
        agents = tuple(a if slot in first else b for slot in range(len(TEAM_GRID_LANES)))
        return agents, TEAM_GRID_LANES, agents

    @property
    def total(self) -> int:
        """How many races the tournament has."""
        return len(self.tracks) * len(self.pairs()) * self.races_per_pair

    def to_json(self) -> dict[str, Any]:
        """A JSON-able dict (stored with the tournament)."""
        data = asdict(self)
        return {
            **data,
            "agents": list(self.agents),
            "tracks": list(self.tracks),
            "background_planners": list(self.background_planners),
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> TournamentSpec:
        """Read back :meth:`to_json`."""
        values = {**data, "agents": tuple(data["agents"]), "tracks": tuple(data["tracks"])}
        # stored before race conditions were a named set: a launch spread alone, simultaneous by default
        values.pop("start_spread", None)
        values.setdefault("conditions", "paper")
        if "background_planners" in values:
            values["background_planners"] = tuple(values["background_planners"])
        return cls(**values)

    def manifest(self) -> Manifest:
        """What this tournament measures, resolved by this process's code (:mod:`arena.manifest`): every agent
        with every parameter, the kart, the conditions of its races and how their seeds and lanes are drawn."""
        conditions = {
            "tracks": list(self.tracks),
            "laps": {track: self.laps or load_any_track(track).laps for track in self.tracks},
            "races_per_pair": self.races_per_pair,
            "races": self.total,
            # the lanes of the pair's first and second agent, by the race's number in its pair and track
            "start_lanes": {"even_races": list(START_LANES), "odd_races": list(START_LANES[::-1])}
            if self.team_size == 1
            else {
                "grid_lanes": list(TEAM_GRID_LANES),
                "first_team_slots": "race 2m: TEAM_SPLITS[m % 3]; race 2m + 1: the other slots (the same seed)",
                "splits": [list(split) for split in TEAM_SPLITS],
            },
            "team_size": self.team_size,
            "conditions": condition_set(self.conditions).to_json(),
            "plan_latency": self.plan_latency,
            "seed": self.seed,
            "race_seeds": "numpy.random.SeedSequence([seed, track, r]).generate_state(1)[0] % 2**31 for race r of "
            "each pair on the track-th track (the same conditions for race r of every pair)",
            "time_limit": time_limit_of(self.time_limit),
            "background_planners": list(self.background_planners),
            "background_planner": background_planner_settings() if self.background_planners else None,
        }
        return build_manifest("tournament", [describe_agent(a) for a in self.agents], self.kart_preset, conditions)


class RaceStore(Protocol):
    """Where a tournament's finished races go (the server's database: ``server.tournament_db``)."""

    def finished_indices(self, tournament_id: str) -> set[int]:
        """Schedule indices of the races stored for ``tournament_id``."""

    def save(self, tournament_id: str, race: FinishedRace) -> None:
        """Store one finished race (atomically: after a crash it is there whole or not at all)."""


@dataclass
class MemoryStore:
    """A :class:`RaceStore` in memory (tests, benchmarks)."""

    races: dict[str, dict[int, FinishedRace]] = field(default_factory=dict)

    def finished_indices(self, tournament_id: str) -> set[int]:
        """Indices stored for the tournament."""
        return set(self.races.get(tournament_id, {}))

    def save(self, tournament_id: str, race: FinishedRace) -> None:
        """Keep the race."""
        self.races.setdefault(tournament_id, {})[race.job.index] = race

    def figures(self, tournament_id: str) -> list[RaceFigures]:
        """The stored races' figures in schedule order."""
        stored = self.races.get(tournament_id, {})
        return [stored[i].figures() for i in sorted(stored)]


@dataclass(frozen=True)
class Progress:
    """Where a tournament stands after a race: races done (stored, this run's and earlier runs') of ``total``."""

    done: int
    total: int
    race: FinishedRace | None  # the race just finished (None: the report before the first race)


ProgressHook = Callable[[Progress], None]
StopCheck = Callable[[], bool]


def default_workers() -> int:
    """Worker processes by default: one per CPU this process may use."""
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)


def run_tournament(
    spec: TournamentSpec,
    store: RaceStore,
    tournament_id: str,
    *,
    backend: Backend = "process",
    workers: int | None = None,
    ray_address: str | None = None,
    record: bool = True,
    on_progress: ProgressHook | None = None,
    should_stop: StopCheck | None = None,
    batch: int = BATCH_RACES,
) -> int:
    """Run the races of ``spec`` that ``store`` does not hold yet, in chunks of at most ``batch`` races
    (:func:`chunks`); store each race as its chunk finishes. Returns the races stored by this call.
    ``should_stop()`` is asked after every race: true ends the run (races in flight are abandoned, not stored;
    a later run re-runs them). The results do not depend on ``batch`` (:func:`arena.race.run_jobs`)."""
    spec.validate()
    done = store.finished_indices(tournament_id)
    pending = [job for job in spec.jobs() if job.index not in done]
    stored = 0
    if on_progress is not None:
        on_progress(Progress(len(done), spec.total, None))
    n_workers = workers or default_workers()
    races = _backend_races(backend, chunks(pending, batch, n_workers), n_workers, ray_address, record)
    try:
        for race in races:
            store.save(tournament_id, race)
            stored += 1
            if on_progress is not None:
                on_progress(Progress(len(done) + stored, spec.total, race))
            if should_stop is not None and should_stop():
                break
    finally:
        races.close()
    return stored


def race_stream(
    jobs: Sequence[RaceJob], *, workers: int | None = None, record: bool = False, batch: int = BATCH_RACES
) -> Generator[FinishedRace, None, None]:
    """Run ``jobs`` in worker processes (chunks of :func:`chunks`), yielding each race as its chunk finishes (not in
    schedule order): for studies that keep their races themselves (:mod:`arena.field`)."""
    n_workers = workers or default_workers()
    return _backend_races("process", chunks(jobs, batch, n_workers), n_workers, None, record)


def chunks(jobs: Sequence[RaceJob], batch: int, workers: int = 1) -> list[tuple[RaceJob, ...]]:
    """``jobs`` cut into chunks of at most ``batch`` races that share a batch key (track, laps, ...:
    :func:`controllers.race.batch_key`), in schedule order; smaller chunks when there are too few races to keep
    ``workers`` busy, and a group's chunks as even as they can be (10 races in at most 8: 5 and 5, not 8 and 2,
    which left one of two workers idle for most of a small tournament)."""
    if batch < 1:
        raise ValueError(f"batch must be >= 1, got {batch}")
    groups: dict[object, list[RaceJob]] = {}
    for job in jobs:
        groups.setdefault(batch_key(job.spec()), []).append(job)
    most = max(1, min(batch, -(-len(jobs) // max(1, workers))))
    cut = []
    for group in groups.values():
        size = math.ceil(len(group) / math.ceil(len(group) / most))  # the fewest chunks of at most ``most``, even
        cut += [tuple(group[i : i + size]) for i in range(0, len(group), size)]
    return cut


def _backend_races(
    backend: Backend, jobs: Sequence[tuple[RaceJob, ...]], workers: int, ray_address: str | None, record: bool
) -> Generator[FinishedRace, None, None]:
    if backend == "inline":
        return (race for chunk in jobs for race in run_jobs(chunk, record))
    if backend == "process":
        return _process_races(jobs, workers, record)
    if backend == "ray":
        return _ray_races(jobs, ray_address, record)
    raise ValueError(f"unknown backend {backend!r}; known: {BACKENDS}")


def start_method() -> str:
    """How worker processes start: a fork server where there is one (a clean process, quick to fork), else spawn."""
    return "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"


MAX_RACE_ATTEMPTS = 3  # a chunk whose worker process dies is run again, up to this many runs in all


class WorkerLostError(RuntimeError):
    """A chunk's worker process died in each of its :data:`MAX_RACE_ATTEMPTS` runs."""


def _worker_pool(context: BaseContext) -> ProcessPoolExecutor:
    """One worker process (a pool of one: a worker that dies breaks only its own pool, and loses only its race)."""
    return ProcessPoolExecutor(max_workers=1, mp_context=context, initializer=die_with_parent)  # type: ignore[arg-type]


def _process_races(
    jobs: Sequence[tuple[RaceJob, ...]], workers: int, record: bool
) -> Generator[FinishedRace, None, None]:
    """Races from ``workers`` worker processes, one chunk each at a time, as their chunks finish. A worker that dies
    loses its current chunk only: that chunk runs again in a fresh worker (at most :data:`MAX_RACE_ATTEMPTS`
    runs)."""
    if not jobs:
        return
    context = multiprocessing.get_context(start_method())
    queue = list(reversed(jobs))
    runs: dict[int, int] = {}  # first job index of a chunk -> runs started
    slots = [_worker_pool(context) for _ in range(min(workers, len(jobs)))]
    running: dict[Future[list[FinishedRace]], tuple[int, tuple[RaceJob, ...]]] = {}  # -> (slot, chunk)

    def lost(slot: int, chunk: tuple[RaceJob, ...]) -> None:
        indices = [job.index for job in chunk]
        if runs[chunk[0].index] >= MAX_RACE_ATTEMPTS:
            raise WorkerLostError(f"races {indices}: their worker process died in all {runs[chunk[0].index]} runs")
        log.warning("races %s: their worker process died; running them again", indices)
        slots[slot].shutdown(wait=False, cancel_futures=True)
        slots[slot] = _worker_pool(context)
        queue.append(chunk)

    try:
        while queue or running:
            busy = {slot for slot, _chunk in running.values()}
            for slot in range(len(slots)):
                if queue and slot not in busy:
                    chunk = queue.pop()
                    runs[chunk[0].index] = runs.get(chunk[0].index, 0) + 1
                    try:
                        running[slots[slot].submit(run_jobs, chunk, record)] = (slot, chunk)
                    except BrokenProcessPool:  # its worker died between chunks
                        lost(slot, chunk)
            if not running:
                continue
            finished, _pending = wait(running, return_when=FIRST_COMPLETED)
            for future in sorted(finished, key=lambda f: running[f][1][0].index):
                slot, chunk = running.pop(future)
                try:
                    races = future.result()
                except BrokenProcessPool:
                    lost(slot, chunk)
                    continue
                yield from races
    finally:
        # stopped early: do not wait for the races in flight
        for pool in slots:
            pool.shutdown(wait=not running, cancel_futures=True)


def _ray_races(
    jobs: Sequence[tuple[RaceJob, ...]], address: str | None, record: bool
) -> Generator[FinishedRace, None, None]:
    """Races as Ray tasks (a chunk each, one CPU), as their chunks finish. Connects to ``address`` (``None``: a
    local Ray, or the cluster of ``RAY_ADDRESS``) unless Ray is already initialised."""
    try:
        import ray
    except ImportError as exc:
        raise RuntimeError("the ray backend needs Ray: pip install 'headtohead-karting[tournament]'") from exc
    if not jobs:
        return
    if not ray.is_initialized():
        ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
    remote: Any = ray.remote(num_cpus=1)(run_jobs)
    running = [remote.remote(chunk, record) for chunk in jobs]
    try:
        while running:
            ready, running = ray.wait(running, num_returns=1)
            for ref in ready:
                yield from ray.get(ref)
    finally:
        for ref in running:
            ray.cancel(ref, force=True)
