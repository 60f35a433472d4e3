"""Free-for-all fields: every agent in races of many karts (``karting reproduce field``).

A field race puts ``field_size`` karts on the world's two-row grid (lanes 2, 3, 1, 4 in each row, the second row
behind the first): the agents in turn, slot by slot, from a different first agent each pair of races
(:meth:`FieldSpec.lineup`). Races come in reversed pairs: races 2m and 2m + 1 have the same seed (the same
conditions per slot) and the second has the first's grid reversed, pole last and last on pole, so each kart
starts once from the front row and once from the back under the same conditions; over every ``len(agents)``
pairs each agent starts from each slot equally often. Under the default ``varied-equal-distance`` conditions
every kart finishes after the race's laps from its own slot, so no slot is nearer the flag; a slot in front is
still a place in front on the road: :func:`slot_wins` reports how many races each slot won, and
:func:`row_effect` how many places a kart loses starting from the back row instead of the front, paired.

Per agent, over every kart it raced (:class:`FieldFigures`): the share of karts that finished (a Wilson
interval), collisions at fault and illegal lane changes per kart-race (bootstrap intervals), and its rating from
every race's finishing order (Plackett-Luce, :mod:`arena.ratings`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

from arena.intervals import Interval, bootstrap_mean, interval_json, wilson
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
    reversed_pairs: bool = True  # races 2m and 2m + 1: the same seed, the grid reversed (races_per_track even)

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
        if self.reversed_pairs and self.races_per_track % 2:
            raise ValueError(f"races_per_track must be even for reversed pairs, got {self.races_per_track}")
        condition_set(self.conditions)
        for track in self.tracks:
            if load_any_track(track).n_lanes < max(DEFAULT_START_LANES):
                raise ValueError(f"track {track!r} has fewer than {max(DEFAULT_START_LANES)} lanes for the grid")
        return self

    def lineup(self, race: int) -> tuple[str, ...]:
        """Race ``race``'s agent in each grid slot (slot 0: pole): the agents in turn from agent ``round mod n``,
        where a round is a pair of races (the second of a pair reversed) or, without pairs, one race."""
        n = len(self.agents)
        round_ = race // 2 if self.reversed_pairs else race
        grid = tuple(self.agents[(round_ + slot) % n] for slot in range(self.field_size))
        return grid[::-1] if self.reversed_pairs and race % 2 else grid

    def seed_of(self, track: int, race: int) -> int:
        """Race ``race`` of track number ``track``'s seed (both races of a reversed pair have the same)."""
        return race_seed(self.seed, track, race // 2 if self.reversed_pairs else race)

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
                seed = self.seed_of(t, r)
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
        """Every field (a manifest's record), the conditions with the named set's values."""
        return {
            **asdict(self),
            "agents": list(self.agents),
            "tracks": list(self.tracks),
            "conditions": condition_set(self.conditions).to_json(),
        }


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
            data[key] = interval_json(getattr(self, key))
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


@dataclass(frozen=True)
class RowEffect:
    """What the row decides, paired: over reversed pairs, the places each kart lost starting from the back row
    instead of the front under the same conditions (back-row place minus front-row place; positive: the front
    row helped), overall and per agent, with bootstrap intervals."""

    pairs: int
    places_lost: float  # mean over karts
    places_lost_ci95: Interval | None
    per_agent: dict[str, tuple[float, Interval | None]]
    same_winner: int  # pairs whose two races the same agent won (the grid did not decide the winning agent)

    def to_json(self) -> dict[str, Any]:
        """Every figure, intervals as ``[low, high]``."""
        interval = interval_json
        return {
            "pairs": self.pairs,
            "places_lost": self.places_lost,
            "places_lost_ci95": interval(self.places_lost_ci95),
            "per_agent": {a: {"places_lost": m, "ci95": interval(ci)} for a, (m, ci) in self.per_agent.items()},
            "same_winner": self.same_winner,
        }


def places(race: RaceFigures) -> list[int]:
    """Each kart's finishing place (1 first): finishers by time, then the karts that did not finish."""
    ranked = sorted(range(len(race.karts)), key=lambda k: (not race.karts[k].finished, race.karts[k].total_time or 0))
    place = [0] * len(race.karts)
    for p, k in enumerate(ranked):
        place[k] = p + 1
    return place


def row_effect(races: Sequence[RaceFigures], front_row: int = len(DEFAULT_START_LANES)) -> RowEffect | None:
    """The paired row effect over the reversed pairs among ``races`` (races ``2m`` and ``2m + 1`` of a schedule
    with the same track; the second's slot ``s`` is the first's ``n - 1 - s``); None without pairs or without a
    second row."""
    by_index = {race.index: race for race in races}
    lost: dict[str, list[float]] = {}
    pairs = same = 0
    for index, first in sorted(by_index.items()):
        second = by_index.get(index + 1)
        if index % 2 or second is None or second.track != first.track:
            continue
        n = len(first.karts)
        if [k.agent for k in second.karts] != [k.agent for k in first.karts][::-1]:
            raise ValueError(f"races {index} and {index + 1} are not a reversed pair")
        pairs += 1
        same += first.winner() is not None and first.winner() == second.winner()
        place_first, place_second = places(first), places(second)
        for slot in range(n):
            mirror = n - 1 - slot
            if (slot < front_row) == (mirror < front_row):
                continue  # the same row in both races
            front, back = (place_first[slot], place_second[mirror])
            if slot >= front_row:
                front, back = back, front
            lost.setdefault(first.karts[slot].agent, []).append(float(back - front))
    every = [v for values in lost.values() for v in values]
    if not every:
        return None  # no pairs, or a field of one row
    per_agent = {a: (sum(v) / len(v), bootstrap_mean(v)) for a, v in sorted(lost.items())}
    mean = sum(every) / len(every)
    return RowEffect(pairs, mean, bootstrap_mean(every), per_agent, same)
