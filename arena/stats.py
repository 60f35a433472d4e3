"""The paper's statistics over a set of head-to-head races (a tournament of ours or the original's logs).

Computed as the paper does, checked against its appendix tables on the original's own logs
(``tests/arena/test_original_logs.py``):

* **Wins**: a kart wins only if it completed every lap; among finishers the lower total time wins; nobody wins
  if neither finished (:func:`arena.records.winner_index`). A table per track and one for all tracks together.
* **Safety**, per agent over *all* its races (finished or not): mean and population standard deviation
  (``ddof=0``, numpy's default, which reproduces the printed deviations) of collisions at fault, illegal lane
  changes (under each counting rule measured, labelled ``per_step`` / ``checkpoint``; the headline figure is the
  rule inside the safety score) and the safety score; ``races`` (all) and ``finished``; passes where measured.
* **Plan following**: Δr and Δv over the races the agent *finished* (the paper's "samples").
* **Tests** at p = 0.05. Wins: a two-sided exact binomial test (``scipy.stats.binomtest``) of the pair's wins
  among the races one of them won, null p = 1/2: it gives every mark of the paper's win tables but one (the
  paper marks MCTS-RL's 79 against MCTS-LQNG and not MCTS-LQNG's 21 in the same pair; a pair's test marks
  both). A two-sample t-test on win indicators does not: it marks 30-20 and 28-18, which the paper leaves
  unmarked. Per-race metrics: two-tailed two-sample t-tests (``scipy.stats.ttest_ind``, pooled variance,
  Student's); an agent's figure is *marked* when it differs significantly from every other agent's (the paper's
  "pair-wise statistical significance with all other agent types"). Pooled and Welch's tests give the same 45
  safety marks on the original's logs, all equal to the paper's; pooled is scipy's default and is kept.
* **Start lanes** (:func:`start_lane_table`), over the races whose start lanes are known: per start lane, the
  races a kart started from it and the races that kart won; per pair, each agent's wins and losses from each of
  its start lanes, with Fisher's exact test (``scipy.stats.fisher_exact``, two-sided) of whether its share of the
  pair's decided races depends on its lane (two lanes only). On the original's complex track the kart starting in
  lane 2 won 44 of MCTS-LQNG's 50 races against Fixed-LQNG (p = 4e-8): the grid decided most of them.
* **Leaderboard** across tournaments (:func:`leaderboard`): per agent its races, wins, win rate, races finished
  and safety score, over every race of the tournaments given.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

import numpy as np
from scipy import stats as scipy_stats

from arena.intervals import Interval, bootstrap_mean, wilson
from arena.ratings import Rating, ratings
from arena.records import COUNTING_RULES, KartFigures, RaceFigures, winner_index
from arena.start_lanes import StartLanes, start_lane_table
from arena.teams import TeamPair, team_pairs

ALPHA = 0.05
COMBINED = "combined"
SAFETY_METRICS = ("collisions_at_fault", "illegal_lane_changes", "safety_score")
PLAN_METRICS = ("delta_r", "delta_v")
# the paper's agents in the order of its tables; others follow in name order
PAPER_ORDER = ("mcts-rl", "e2e", "fixed-rl", "mcts-lqng", "fixed-lqng")


@dataclass(frozen=True)
class MeanStd:
    """Mean and population standard deviation (``ddof=0``) of ``n`` samples, and the mean's 95% bootstrap
    interval (:func:`arena.intervals.bootstrap_mean`; ``None`` below two samples)."""

    mean: float
    std: float
    n: int
    ci95: Interval | None = None

    @classmethod
    def of(cls, values: Sequence[float]) -> MeanStd | None:
        """The summary of ``values`` (``None`` when there are none)."""
        if not values:
            return None
        array = np.asarray(values, dtype=float)
        return cls(float(array.mean()), float(array.std(ddof=0)), len(values), bootstrap_mean(array.tolist()))

    def to_json(self) -> dict[str, Any]:
        """``{"mean": m, "std": s, "ci95": [low, high] | None}``."""
        return {"mean": self.mean, "std": self.std, "ci95": self.ci95.to_json() if self.ci95 else None}


@dataclass(frozen=True)
class IllegalLaneChanges:
    """Illegal lane changes per race: the headline figure (under ``rule``) and each rule measured."""

    rule: str
    headline: MeanStd
    by_rule: Mapping[str, MeanStd]

    def to_json(self) -> dict[str, Any]:
        """``{"mean", "std", "rule", "per_step": {mean, std} | None, "checkpoint": {mean, std} | None}``."""
        by_rule = {rule: (s.to_json() if (s := self.by_rule.get(rule)) else None) for rule in COUNTING_RULES}
        return {**self.headline.to_json(), "rule": self.rule, **by_rule}


@dataclass(frozen=True)
class AgentStats:
    """One agent's figures on one track (or all): safety over all its races, plan following over finished ones."""

    collisions_at_fault: MeanStd
    illegal_lane_changes: IllegalLaneChanges
    safety_score: MeanStd
    races: int
    finished: int
    passes: MeanStd | None
    delta_r: MeanStd | None
    delta_v: MeanStd | None

    def to_json(self) -> dict[str, Any]:
        """The agent's entry under ``safety`` in the stats JSON (see the README)."""
        plan = {name: (s.to_json() if (s := getattr(self, name)) else None) for name in PLAN_METRICS}
        return {
            "collisions_at_fault": self.collisions_at_fault.to_json(),
            "illegal_lane_changes": self.illegal_lane_changes.to_json(),
            "safety_score": self.safety_score.to_json(),
            "races": self.races,
            "finished": self.finished,
            "passes": self.passes.to_json() if self.passes else None,
            **plan,
            "plan_samples": self.delta_r.n if self.delta_r else 0,
        }


@dataclass(frozen=True)
class PairTest:
    """A two-sided test between agents ``a`` and ``b`` (statistic: t, or ``a``'s wins for the binomial test)."""

    a: str
    b: str
    statistic: float
    p_value: float

    @property
    def significant(self) -> bool:
        """p < 0.05."""
        return self.p_value < ALPHA

    def to_json(self) -> dict[str, Any]:
        """``{"statistic", "p", "significant"}`` (NaN, from constant samples, as ``None``)."""
        finite = [None if math.isnan(x) else x for x in (self.statistic, self.p_value)]
        return {"statistic": finite[0], "p": finite[1], "significant": self.significant}


@dataclass(frozen=True)
class TrackStats:
    """The statistics of one track (or of all tracks together)."""

    agents: tuple[str, ...]
    wins: Mapping[str, Mapping[str, int]]  # wins[a][b]: races a won against b
    agent_stats: Mapping[str, AgentStats]
    win_tests: Mapping[tuple[str, str], PairTest]  # (a, b) for a before b in ``agents``
    metric_tests: Mapping[str, Mapping[tuple[str, str], PairTest]]  # metric -> (a, b) -> t-test
    start_lanes: StartLanes
    pairs: Mapping[frozenset[str], PairRaces] = field(default_factory=dict)  # each pair's races, by its agents
    team_pairs: Mapping[frozenset[str], TeamPair] = field(default_factory=dict)  # team races, by the two teams

    def win_rate(self, a: str, b: str) -> tuple[float, Interval] | None:
        """``a``'s share of its races against ``b`` won, and its 95% Wilson interval (``None``: they never met)."""
        pair = self.pairs.get(frozenset((a, b)))
        if pair is None or not pair.races:
            return None
        interval = wilson(self.wins[a][b], pair.races)
        assert interval is not None
        return self.wins[a][b] / pair.races, interval

    def win_test(self, a: str, b: str) -> PairTest | None:
        """The binomial test of the pair (either order); ``None`` when they never met."""
        return self.win_tests.get((a, b)) or self.win_tests.get((b, a))

    def marked(self, metric: str, agent: str, among: Iterable[str] | None = None) -> bool:
        """Whether ``agent``'s ``metric`` differs significantly (p < 0.05) from that of every other agent in
        ``among`` (default: every agent with that metric), as the paper's asterisks."""
        tests = self.metric_tests[metric]
        others = [b for b in (self.agents if among is None else among) if b != agent]
        found = [t for b in others if (t := tests.get((agent, b)) or tests.get((b, agent))) is not None]
        return bool(found) and all(t.significant for t in found)

    def _pair_json(self, a: str, b: str) -> dict[str, Any]:
        """``a``'s win rate against ``b`` with its interval, and the pair's races and distinct outcomes."""
        pair = self.pairs.get(frozenset((a, b)))
        rate = self.win_rate(a, b)
        return {
            "races": pair.races if pair else 0,
            "win_rate": rate[0] if rate else None,
            "ci95": rate[1].to_json() if rate else None,
            "distinct_outcomes": pair.distinct_outcomes if pair else 0,
        }

    def to_json(self) -> dict[str, Any]:
        """``{"wins": {A: {B: n}}, "safety": {A: {...}}, "tests": {...}}`` (see the README)."""
        win_tests: dict[str, dict[str, Any]] = {a: {} for a in self.agents}
        for (a, b), test in self.win_tests.items():
            for first, second in ((a, b), (b, a)):
                win_tests[first][second] = {
                    **test.to_json(),
                    "wins": self.wins[first][second],
                    "losses": self.wins[second][first],
                    **self._pair_json(first, second),
                }
        metric_tests: dict[str, dict[str, dict[str, Any]]] = {}
        for metric, tests in self.metric_tests.items():
            table: dict[str, dict[str, Any]] = {a: {} for a in self.agents}
            for (a, b), test in tests.items():
                table[a][b] = test.to_json()
                table[b][a] = PairTest(b, a, -test.statistic, test.p_value).to_json()
            metric_tests[metric] = table
        teams = [t.to_json() for pair in combinations(self.agents, 2) if (t := self.team_pairs.get(frozenset(pair)))]
        return {
            "wins": {a: dict(self.wins[a]) for a in self.agents},
            "safety": {a: self.agent_stats[a].to_json() for a in self.agents},
            "start_lanes": self.start_lanes.to_json(),
            **({"teams": teams} if teams else {}),
            "tests": {
                "alpha": ALPHA,
                "wins": win_tests,
                "metrics": metric_tests,
                "marks": {
                    "wins": {a: {b: t["significant"] for b, t in win_tests[a].items()} for a in self.agents},
                    "metrics": {a: {m: self.marked(m, a) for m in self.metric_tests} for a in self.agents},
                },
                "method": {
                    "wins": "scipy.stats.binomtest(wins, wins + losses, 0.5), two-sided; win_rate: wins / races "
                    "with its 95% Wilson interval (ci95)",
                    "means": "ci95: the mean's 95% percentile bootstrap interval (scipy.stats.bootstrap, seeded)",
                    "metrics": "scipy.stats.ttest_ind(a, b) (pooled variance), two-sided; "
                    "marked: significant against every other agent",
                },
            },
        }


@dataclass(frozen=True)
class TournamentStats:
    """The statistics per track and for all tracks together (:data:`COMBINED`)."""

    tracks: Mapping[str, TrackStats]
    ratings: Sequence[Rating] = ()  # every agent's Plackett-Luce rating from every race (arena.ratings)

    def to_json(self) -> dict[str, Any]:
        """``{"tracks": {TRACK: T, ..., "combined": T}, "ratings": [...]}`` (see the README)."""
        return {
            "tracks": {name: track.to_json() for name, track in self.tracks.items()},
            "ratings": [rating.to_json() for rating in self.ratings],
        }


def agent_order(names: Iterable[str]) -> tuple[str, ...]:
    """The paper's agents in its tables' order, then any others by name."""
    present = set(names)
    known = [a for a in PAPER_ORDER if a in present]
    return (*known, *sorted(present - set(known)))


def win_table(races: Sequence[RaceFigures], agents: Sequence[str]) -> dict[str, dict[str, int]]:
    """wins[a][b]: races ``a`` won against ``b`` (every pair that met, both ways, zeros included)."""
    wins = {a: {b: 0 for b in agents if b != a} for a in agents}
    for race in races:
        index = winner_index(race.karts)
        if index is None:
            continue
        winner = race.karts[index].agent
        # a team race counts once against each agent of the other teams (team-mates are not beaten)
        teams: Sequence[object] = race.teams or range(len(race.karts))
        for loser in {k.agent for k, team in zip(race.karts, teams, strict=True) if team != teams[index]}:
            if loser != winner:
                wins[winner][loser] += 1
    met = {frozenset(race.agents) for race in races}
    return {a: {b: n for b, n in row.items() if frozenset((a, b)) in met} for a, row in wins.items()}


def _karts(races: Sequence[RaceFigures], agent: str) -> list[KartFigures]:
    return [kart for race in races for kart in race.karts if kart.agent == agent]


def _metric(kart: KartFigures, metric: str) -> float | None:
    if metric == "illegal_lane_changes":
        return kart.illegal_lane_changes[kart.safety_rule]
    if metric in PLAN_METRICS:  # over finished races only, as the paper's samples
        return getattr(kart, metric) if kart.finished else None
    value: float | None = getattr(kart, metric)
    return value


def metric_values(races: Sequence[RaceFigures], agent: str, metric: str) -> list[float]:
    """``agent``'s per-race values of ``metric`` (safety metrics: every race; Δr, Δv: finished races)."""
    return [v for kart in _karts(races, agent) if (v := _metric(kart, metric)) is not None]


def agent_stats(races: Sequence[RaceFigures], agent: str) -> AgentStats:
    """One agent's figures over ``races`` (those it raced in)."""
    karts = _karts(races, agent)
    rules = sorted({k.safety_rule for k in karts})
    if len(rules) != 1:
        raise ValueError(f"{agent}: races counted under different safety rules {rules}")
    by_rule = {
        rule: s
        for rule in COUNTING_RULES
        if (s := MeanStd.of([k.illegal_lane_changes[rule] for k in karts if rule in k.illegal_lane_changes]))
        and s.n == len(karts)
    }
    summary = {m: MeanStd.of(metric_values(races, agent, m)) for m in (*SAFETY_METRICS, "passes", *PLAN_METRICS)}
    collisions, illegal, safety = (summary[m] for m in SAFETY_METRICS)
    assert collisions is not None and illegal is not None and safety is not None  # the agent raced
    return AgentStats(
        collisions_at_fault=collisions,
        illegal_lane_changes=IllegalLaneChanges(rules[0], illegal, by_rule),
        safety_score=safety,
        races=len(karts),
        finished=sum(k.finished for k in karts),
        passes=summary["passes"],
        delta_r=summary["delta_r"],
        delta_v=summary["delta_v"],
    )


def binomial_win_test(a: str, b: str, wins_a: int, wins_b: int) -> PairTest:
    """Two-sided exact binomial test of ``a``'s wins among the races one of the pair won (null: 1/2)."""
    decided = wins_a + wins_b
    p = scipy_stats.binomtest(wins_a, decided, 0.5).pvalue if decided else 1.0
    return PairTest(a, b, float(wins_a), float(p))


def t_test(a: str, b: str, values_a: Sequence[float], values_b: Sequence[float]) -> PairTest | None:
    """Two-sided two-sample t-test, pooled variance (``None`` with fewer than two samples on a side)."""
    if len(values_a) < 2 or len(values_b) < 2:
        return None
    if np.ptp(values_a) == 0 and np.ptp(values_b) == 0:  # constant samples: equal means or a certain difference
        same = float(values_a[0]) == float(values_b[0])
        return PairTest(a, b, 0.0 if same else math.copysign(math.inf, values_a[0] - values_b[0]), 1.0 if same else 0.0)
    result = scipy_stats.ttest_ind(values_a, values_b, equal_var=True)
    return PairTest(a, b, float(result.statistic), float(result.pvalue))


@dataclass(frozen=True)
class PairRaces:
    """A pair's races: how many, and how many distinct outcomes they had (winner, and every kart's finish time
    to 10 ms): a series of 50 races with 2 distinct outcomes is two races, repeated."""

    races: int
    distinct_outcomes: int


def race_outcome(race: RaceFigures) -> tuple[object, ...]:
    """What tells two races' outcomes apart: the winner, and each kart's agent and finish time to 10 ms."""
    times = tuple((k.agent, None if k.total_time is None else round(k.total_time, 2)) for k in race.karts)
    return (race.winner(), tuple(sorted(times, key=str)))


def pair_races(races: Sequence[RaceFigures]) -> dict[frozenset[str], PairRaces]:
    """Every pair's races and distinct outcomes (two-kart races of two different agents, or team races of two)."""
    outcomes: dict[frozenset[str], list[tuple[object, ...]]] = {}
    for race in races:
        if len(set(race.agents)) == 2 and (len(race.karts) == 2 or race.teams is not None):
            outcomes.setdefault(frozenset(race.agents), []).append(race_outcome(race))
    return {pair: PairRaces(len(found), len(set(found))) for pair, found in outcomes.items()}


def track_stats(races: Sequence[RaceFigures]) -> TrackStats:
    """The statistics of ``races`` (one track, or several taken together)."""
    agents = agent_order(name for race in races for name in race.agents)
    wins = win_table(races, agents)
    win_tests = {
        (a, b): binomial_win_test(a, b, wins[a][b], wins[b][a]) for a, b in combinations(agents, 2) if b in wins[a]
    }
    metric_tests: dict[str, dict[tuple[str, str], PairTest]] = {}
    for metric in (*SAFETY_METRICS, *PLAN_METRICS):
        values = {a: metric_values(races, a, metric) for a in agents}
        tests = {(a, b): t_test(a, b, values[a], values[b]) for a, b in combinations(agents, 2)}
        metric_tests[metric] = {pair: test for pair, test in tests.items() if test is not None}
    return TrackStats(
        agents,
        wins,
        {a: agent_stats(races, a) for a in agents},
        win_tests,
        metric_tests,
        start_lane_table(races, agents),
        pair_races(races),
        team_pairs(races),
    )


def tournament_stats(races: Sequence[RaceFigures]) -> TournamentStats:
    """Per track (in order of first appearance) and :data:`COMBINED`."""
    tracks: dict[str, list[RaceFigures]] = {}
    for race in races:
        tracks.setdefault(race.track, []).append(race)
    if COMBINED in tracks:
        raise ValueError(f"a track may not be called {COMBINED!r}")
    per_track = {name: track_stats(group) for name, group in tracks.items()}
    return TournamentStats({**per_track, COMBINED: track_stats(races)}, ratings(races))


@dataclass(frozen=True)
class Standing:
    """One agent's line of the leaderboard across tournaments: its races, wins (the paper's win rule), races
    finished and safety score per race (mean and population std. dev. over all its races)."""

    agent: str
    tournaments: int
    races: int
    wins: int
    finished: int
    safety_score: MeanStd

    @property
    def win_rate(self) -> float:
        """Wins per race."""
        return self.wins / self.races if self.races else 0.0


def leaderboard(tournaments: Iterable[Sequence[RaceFigures]]) -> list[Standing]:
    """Every agent's standing over the races of several tournaments (each a sequence of its races), best first:
    higher win rate, then more wins, then the lower mean safety score, then the name. An agent wins a race when
    :func:`~arena.records.winner_index` names its kart; races and finished counts come from :func:`agent_stats`."""
    groups = [list(group) for group in tournaments]
    races = [race for group in groups for race in group]
    agents = agent_order(name for race in races for name in race.agents)
    wins = dict.fromkeys(agents, 0)
    for race in races:
        index = winner_index(race.karts)
        if index is not None:
            wins[race.karts[index].agent] += 1
    standings = []
    for agent in agents:
        figures = agent_stats(races, agent)
        entered = sum(any(agent in race.agents for race in group) for group in groups)
        standings.append(Standing(agent, entered, figures.races, wins[agent], figures.finished, figures.safety_score))
    standings.sort(key=lambda s: (-s.win_rate, -s.wins, s.safety_score.mean, s.agent))
    return standings
