"""Free-for-all fields: every agent in races of many karts (``karting reproduce field``).

A field race puts ``field_size`` karts on the world's two-row grid (lanes 2, 3, 1, 4 in each row, the second row
behind the first): the agents in turn, slot by slot, from a different first agent each race
(:meth:`FieldSpec.lineup`), so over every ``len(agents)`` consecutive races each agent starts from each slot once.
Under the default ``varied-equal-distance`` conditions every kart finishes after the race's laps from its own
slot, so no slot is nearer the flag; a slot in front is still a place in front on the road, which the rotation
spreads evenly over the agents, and :func:`slot_wins` reports how much it decides.

Per agent, over every kart it raced (:class:`FieldFigures`): the share of karts that finished (a Wilson
interval), collisions at fault and illegal lane changes per kart-race (bootstrap intervals), and its rating from
every race's finishing order (Plackett-Luce, :mod:`arena.ratings`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

from arena.intervals import Interval, bootstrap_mean, wilson
from arena.race import RaceJob
from arena.records import PER_STEP, RaceFigures, winner_index
from arena.tournament import race_seed
from controllers.race import load_any_track
from controllers.registry import validate_agent
from sim_core.conditions import condition_set
from sim_core.world import DEFAULT_START_LANES, MAX_KARTS, grid_lanes

FIELD_TRACKS = ("oval", "complex", "brands-hatch")


@dataclass(frozen=True)
class FieldSpec:
    """What a free-for-all study races: agents (registered names, with parameters or ``@PACE``), tracks, karts per
    race, races per track, the seed and the race conditions."""

    agents: tuple[str, ...]
    tracks: tuple[str, ...] = FIELD_TRACKS
    field_size: int = MAX_KARTS
    races_per_track: int = 40
    seed: int = 0
    conditions: str = "varied-equal-distance"
    laps: int | None = None  # None: each track's
    time_limit: float | None = None  # [s] None: the rules' limit

    def validate(self) -> FieldSpec:
        """This spec, or a ValueError saying what is wrong."""
        if len(set(self.agents)) != len(self.agents) or len(self.agents) < 2:
            raise ValueError(f"give two or more different agents, got {list(self.agents)}")
        for agent in self.agents:
            validate_agent(agent)
        if not 2 <= self.field_size <= MAX_KARTS:
            raise ValueError(f"field_size must be in 2..{MAX_KARTS}, got {self.field_size}")
        if self.races_per_track < 1:
            raise ValueError(f"races_per_track must be >= 1, got {self.races_per_track}")
        condition_set(self.conditions)
        for track in self.tracks:
            if load_any_track(track).n_lanes < max(DEFAULT_START_LANES):
                raise ValueError(f"track {track!r} has fewer than {max(DEFAULT_START_LANES)} lanes for the grid")
        return self

    def lineup(self, race: int) -> tuple[str, ...]:
        """Race ``race``'s agent in each grid slot (slot 0: pole): the agents in turn from agent ``race mod n``."""
        n = len(self.agents)
        return tuple(self.agents[(race + slot) % n] for slot in range(self.field_size))

    @property
    def start_lanes(self) -> tuple[int, ...]:
        """Each slot's lane: the world's default grid (lanes 2, 3, 1, 4 in each row)."""
        return grid_lanes(self.field_size)

    @property
    def total(self) -> int:
        """How many races the study has."""
        return len(self.tracks) * self.races_per_track

    def jobs(self) -> list[RaceJob]:
        """The schedule: per track, ``races_per_track`` races; race ``r`` of every track has the seed of ``r``."""
        jobs: list[RaceJob] = []
        for t, track in enumerate(self.tracks):
            for r in range(self.races_per_track):
                seed = race_seed(self.seed, t, r)
                job = RaceJob(
                    len(jobs),
                    track,
                    self.lineup(r),
                    seed,
                    self.start_lanes,
                    self.laps,
                    self.time_limit,
                    conditions=self.conditions,
                )
                jobs.append(job)
        return jobs

    def to_json(self) -> dict[str, Any]:
        """Every field (a manifest's record)."""
        return {**asdict(self), "agents": list(self.agents), "tracks": list(self.tracks)}


@dataclass(frozen=True)
class FieldFigures:
    """One agent's figures over every kart it raced in a set of field races."""

    agent: str
    karts: int  # kart-races
    finished: int
    finished_ci95: Interval | None  # of the share finished
    wins: int  # races a kart of this agent won
    races: int  # races with at least one kart of this agent
    collisions_at_fault: float  # per kart-race
    collisions_ci95: Interval | None
    illegal_lane_changes: float  # per kart-race (the per-step rule)
    illegal_ci95: Interval | None

    @property
    def finish_rate(self) -> float:
        """The share of its karts that finished."""
        return self.finished / self.karts if self.karts else 0.0

    def to_json(self) -> dict[str, Any]:
        """Every figure, intervals as ``[low, high]``."""
        data = asdict(self)
        for key in ("finished_ci95", "collisions_ci95", "illegal_ci95"):
            interval = getattr(self, key)
            data[key] = interval.to_json() if interval is not None else None
        return {**data, "finish_rate": self.finish_rate}


def field_figures(races: Sequence[RaceFigures]) -> dict[str, FieldFigures]:
    """Each agent's :class:`FieldFigures` over ``races``, by agent name in sorted order."""
    figures: dict[str, FieldFigures] = {}
    for agent in sorted({a for race in races for a in race.agents}):
        karts = [k for race in races for k in race.karts if k.agent == agent]
        entered = [race for race in races if agent in race.agents]
        wins = sum(race.winner() == agent for race in entered)
        finished = sum(k.finished for k in karts)
        collisions = [float(k.collisions_at_fault) for k in karts]
        illegal = [float(k.illegal_lane_changes[PER_STEP]) for k in karts]
        figures[agent] = FieldFigures(
            agent,
            len(karts),
            finished,
            wilson(finished, len(karts)),
            wins,
            len(entered),
            sum(collisions) / len(karts),
            bootstrap_mean(collisions),
            sum(illegal) / len(karts),
            bootstrap_mean(illegal),
        )
    return figures


def slot_wins(races: Sequence[RaceFigures]) -> list[int]:
    """How many races the kart in each grid slot won (slot 0: pole; a race nobody finished counts for none)."""
    size = max((len(race.karts) for race in races), default=0)
    wins = [0] * size
    for race in races:
        winner = winner_index(race.karts)
        if winner is not None:
            wins[winner] += 1
    return wins
