"""How races went by start lane: per lane, the races a kart started from it and that kart's wins and losses; per
pair of agents, each one's record by its start lane with Fisher's exact test (``scipy.stats.fisher_exact``,
two-sided) of whether its share of the pair's decided races depends on the lane (two lanes only). On the
original's complex track the kart starting in lane 2 won 44 of MCTS-LQNG's 50 races against Fixed-LQNG
(p = 4e-8): the grid decided most of them."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from scipy import stats as scipy_stats

from arena.records import RaceFigures, winner_index

ALPHA = 0.05


@dataclass(frozen=True)
class LaneRecord:
    """Races from one start lane: how many, how many the kart from that lane won and lost (the rest nobody won)."""

    races: int
    wins: int
    losses: int

    def to_json(self) -> dict[str, int]:
        """``{"races", "wins", "losses"}``."""
        return {"races": self.races, "wins": self.wins, "losses": self.losses}


@dataclass(frozen=True)
class PairLanes:
    """One agent's record against another (the pair is its key in :class:`StartLanes`) by its start lane, and
    Fisher's exact test of whether its share of the decided races depends on that lane (``None`` unless it
    started from exactly two lanes)."""

    by_lane: Mapping[int, LaneRecord]
    fisher_p: float | None

    def to_json(self) -> dict[str, Any]:
        """``{"by_lane": {LANE: {"races", "wins", "losses"}}, "fisher_p": p | None, "significant": bool}``."""
        return {
            "by_lane": {str(lane): record.to_json() for lane, record in self.by_lane.items()},
            "fisher_p": self.fisher_p,
            "significant": self.fisher_p is not None and self.fisher_p < ALPHA,
        }


@dataclass(frozen=True)
class StartLanes:
    """How races went by start lane (races with known start lanes only): per lane, the races a kart started from
    it and that kart's wins and losses; per ordered pair of agents that met in two-kart races, the first one's
    record by its start lane."""

    races: int  # races with known start lanes
    by_lane: Mapping[int, LaneRecord]
    pairs: Mapping[tuple[str, str], PairLanes]

    def to_json(self) -> dict[str, Any]:
        """``{"races": n, "by_lane": {LANE: {...}}, "pairs": {A: {B: {...}}}}``."""
        pairs: dict[str, dict[str, Any]] = {}
        for (a, b), split in self.pairs.items():
            pairs.setdefault(a, {})[b] = split.to_json()
        return {
            "races": self.races,
            "by_lane": {str(lane): record.to_json() for lane, record in self.by_lane.items()},
            "pairs": pairs,
        }


def _lane_record(outcomes: Sequence[bool | None]) -> LaneRecord:
    """``outcomes``: per race True (won), False (lost), None (nobody won)."""
    return LaneRecord(len(outcomes), sum(o is True for o in outcomes), sum(o is False for o in outcomes))


def start_lane_table(races: Sequence[RaceFigures], agents: Sequence[str]) -> StartLanes:
    """Wins and losses by start lane over the races whose start lanes are known (see :class:`StartLanes`)."""
    known = [race for race in races if race.start_lanes is not None]
    per_lane: dict[int, list[bool | None]] = {}
    per_pair: dict[tuple[str, str], dict[int, list[bool | None]]] = {}
    for race in known:
        assert race.start_lanes is not None
        index = winner_index(race.karts)
        for k, lane in enumerate(race.start_lanes):
            per_lane.setdefault(lane, []).append(None if index is None else index == k)
        if len(race.karts) != 2 or race.agents[0] == race.agents[1]:
            continue
        for k in (0, 1):
            outcome = None if index is None else index == k
            pair = (race.agents[k], race.agents[1 - k])
            per_pair.setdefault(pair, {}).setdefault(race.start_lanes[k], []).append(outcome)
    pairs = {}
    for pair, lanes in per_pair.items():
        by_lane = {lane: _lane_record(lanes[lane]) for lane in sorted(lanes)}
        p = None
        if len(by_lane) == 2:
            table = [[r.wins, r.losses] for r in by_lane.values()]
            p = float(scipy_stats.fisher_exact(table).pvalue)
        pairs[pair] = PairLanes(by_lane, p)
    by_lane = {lane: _lane_record(per_lane[lane]) for lane in sorted(per_lane)}
    ordered = dict(sorted(pairs.items(), key=lambda item: (agents.index(item[0][0]), agents.index(item[0][1]))))
    return StartLanes(len(known), by_lane, ordered)
