"""Team races scored: points by finishing place, the race's winning team, and per-team figures over many races
with 95% intervals.

The scoring is the original team experiment's (its ``experiment_log_parser.py``; ``../shared/spec/teams.md`` §3),
which a points table can replace:

* a kart finishes if it completed every lap; finishers are placed by race time, equal times in kart order (the
  original's parser keeps log order; :attr:`TeamResult.tied` says when that decided a place);
* places pay ``points`` (the original's 10 / 7.5 / 6 / 4); a kart that did not finish scores 0 and takes no place;
* the race is won by the team of the fastest finisher (none when nobody finished); a team's points are its karts'.

A race's teams are ``RaceFigures.teams`` (one label per kart).

Cooperation, per team over its races: contacts between its own karts, passes of one of its karts by another (a
team-mate let by), and races in which one of its karts **held a rival for a team-mate** at the flag
(:func:`rival_held`): it finished directly behind its team-mate and directly ahead of a rival no more than
:data:`HOLD_GAP` behind it, a rival that was on its tail and did not get by.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from arena.intervals import Interval, bootstrap_mean, interval_json, wilson
from arena.records import RaceFigures

ORIGINAL_POINTS: tuple[float, ...] = (10.0, 7.5, 6.0, 4.0)  # 1st, 2nd, 3rd, 4th (the original's team races)
HOLD_GAP = 1.0  # [s] a rival finishing within this of the kart ahead was on its tail at the flag


@dataclass(frozen=True)
class TeamResult:
    """One race's outcome for its teams."""

    order: tuple[int, ...]  # the finishers' kart indices, first place first
    winner: str | None  # the team of the fastest finisher (None: nobody finished)
    points: Mapping[str, float]  # team -> the points of its karts
    tied: bool  # two finishers with the same race time (kart order placed them)

    @property
    def points_winner(self) -> str | None:
        """The team with the most points (None: a tie for the most, or no points at all)."""
        ranked = sorted(self.points.items(), key=lambda item: -item[1])
        if not ranked or ranked[0][1] == 0.0 or (len(ranked) > 1 and ranked[1][1] == ranked[0][1]):
            return None
        return ranked[0][0]


def race_teams(race: RaceFigures) -> tuple[str, ...]:
    """Each kart's team; ``ValueError`` for a race without teams."""
    if race.teams is None or len(race.teams) != len(race.karts):
        raise ValueError(f"race {race.index} on {race.track} has no team for every kart")
    return race.teams


def team_result(race: RaceFigures, points: Sequence[float] = ORIGINAL_POINTS) -> TeamResult:
    """Place the finishers, pay the places ``points`` and name the winning team."""
    teams = race_teams(race)
    finishers = sorted((k.total_time, i) for i, k in enumerate(race.karts) if k.finished and k.total_time is not None)
    order = tuple(i for _, i in finishers)
    scored = dict.fromkeys(teams, 0.0)
    for place, kart in enumerate(order):
        scored[teams[kart]] += points[place] if place < len(points) else 0.0
    times = [time for time, _ in finishers]
    return TeamResult(order, teams[order[0]] if order else None, scored, len(set(times)) < len(times))


@dataclass(frozen=True)
class TeamFigures:
    """One team's figures over races it took part in (per kart-race: summed over its karts, over karts × races)."""

    team: str
    races: int
    wins: int  # races its fastest finisher won
    wins_ci95: Interval | None  # Wilson
    mean_points: float  # per race, the team's karts together
    points_ci95: Interval | None  # bootstrap
    kart_races: int
    collisions: float  # collisions at fault per kart-race
    illegal_lane_changes: float  # per kart-race, under each kart's safety rule
    safety: float  # the two together
    safety_ci95: Interval | None  # bootstrap over kart-races
    unfinished: int  # karts that did not finish
    teammate_contacts: int | None = None  # contacts between its own karts over its races (None: not measured)
    teammate_passes: int | None = None  # passes of one of its karts by another over its races (None: not measured)
    races_with_teammate_pass: int | None = None  # races in which one of its karts let another by
    races_with_rival_held: int = 0  # races in which one of its karts held a rival for a team-mate (rival_held)

    @property
    def win_rate(self) -> float:
        """Share of its races won."""
        return self.wins / self.races if self.races else 0.0

    @property
    def teammate_contacts_per_race(self) -> float | None:
        """Contacts between its own karts per race (None: not measured)."""
        return None if self.teammate_contacts is None or not self.races else self.teammate_contacts / self.races

    @property
    def teammate_pass_share(self) -> float | None:
        """The share of its races in which one of its karts passed another (None: not measured)."""
        known = self.races_with_teammate_pass
        return None if known is None or not self.races else known / self.races

    @property
    def rival_held_share(self) -> float:
        """The share of its races in which one of its karts held a rival for a team-mate at the flag."""
        return self.races_with_rival_held / self.races if self.races else 0.0

    def to_json(self) -> dict[str, object]:
        """The figures as JSON."""
        interval = interval_json
        return {
            "team": self.team,
            "races": self.races,
            "wins": self.wins,
            "win_rate": self.win_rate,
            "wins_ci95": interval(self.wins_ci95),
            "mean_points": self.mean_points,
            "points_ci95": interval(self.points_ci95),
            "kart_races": self.kart_races,
            "collisions_per_kart_race": self.collisions,
            "illegal_lane_changes_per_kart_race": self.illegal_lane_changes,
            "safety_per_kart_race": self.safety,
            "safety_ci95": interval(self.safety_ci95),
            "unfinished_karts": self.unfinished,
            "teammate_contacts": self.teammate_contacts,
            "teammate_contacts_per_race": self.teammate_contacts_per_race,
            "teammate_passes": self.teammate_passes,
            "races_with_teammate_pass": self.races_with_teammate_pass,
            "teammate_pass_share": self.teammate_pass_share,
            "races_with_rival_held": self.races_with_rival_held,
            "rival_held_share": self.rival_held_share,
        }


def team_figures(races: Sequence[RaceFigures], points: Sequence[float] = ORIGINAL_POINTS) -> dict[str, TeamFigures]:
    """Every team's figures over ``races`` (each race counts for the teams in it), teams in order of appearance."""
    played: dict[str, list[float]] = {}
    won: dict[str, int] = {}
    safety: dict[str, list[int]] = {}
    collisions: dict[str, int] = {}
    unfinished: dict[str, int] = {}
    teammate: dict[str, int | None] = {}
    passing: dict[str, int | None] = {}
    passing_races: dict[str, int | None] = {}
    holding: dict[str, int] = {}
    for race in races:
        result = team_result(race, points)
        for team in rival_held(race, result):
            holding[team] = holding.get(team, 0) + 1
        for team, contacts in _between_teammates(race, "contacts_with").items():
            teammate[team] = _add(teammate.get(team, 0), contacts)
        for team, passes in _between_teammates(race, "passes_of", both_ways=True).items():
            passing[team] = _add(passing.get(team, 0), passes)
            passing_races[team] = _add(passing_races.get(team, 0), None if passes is None else int(passes > 0))
        for team, scored in result.points.items():
            played.setdefault(team, []).append(scored)
            won[team] = won.get(team, 0) + (result.winner == team)
        for team, kart in zip(race_teams(race), race.karts, strict=True):
            safety.setdefault(team, []).append(kart.safety_score)
            collisions[team] = collisions.get(team, 0) + kart.collisions_at_fault
            unfinished[team] = unfinished.get(team, 0) + (not kart.finished)
    figures = {}
    for team, scores in played.items():
        kart_races = len(safety[team])
        total_safety = sum(safety[team])
        figures[team] = TeamFigures(
            team=team,
            races=len(scores),
            wins=won[team],
            wins_ci95=wilson(won[team], len(scores)),
            mean_points=sum(scores) / len(scores),
            points_ci95=bootstrap_mean(scores),
            kart_races=kart_races,
            collisions=collisions[team] / kart_races,
            illegal_lane_changes=(total_safety - collisions[team]) / kart_races,
            safety=total_safety / kart_races,
            safety_ci95=bootstrap_mean(safety[team]),
            unfinished=unfinished[team],
            teammate_contacts=teammate.get(team),
            teammate_passes=passing.get(team),
            races_with_teammate_pass=passing_races.get(team),
            races_with_rival_held=holding.get(team, 0),
        )
    return figures


def rival_held(race: RaceFigures, result: TeamResult | None = None) -> set[str]:
    """The teams of ``race`` one of whose karts held a rival for a team-mate at the flag: it finished directly
    behind a team-mate and directly ahead of a kart of another team that finished at most :data:`HOLD_GAP`
    behind it."""
    teams = race_teams(race)
    order = (result or team_result(race)).order
    held = set()
    for place in range(1, len(order) - 1):
        mate, kart, rival = order[place - 1], order[place], order[place + 1]
        if teams[mate] != teams[kart] or teams[rival] == teams[kart]:
            continue
        behind, ahead = race.karts[rival].total_time, race.karts[kart].total_time
        if behind is not None and ahead is not None and behind - ahead <= HOLD_GAP:
            held.add(teams[kart])
    return held


def _add(total: int | None, more: int | None) -> int | None:
    return None if total is None or more is None else total + more


def _between_teammates(race: RaceFigures, counts: str, both_ways: bool = False) -> dict[str, int | None]:
    """Per team of ``race``: the sum of its karts' per-kart ``counts`` (a :class:`KartFigures` field, by kart) over
    pairs of its karts, each pair once (``both_ways``: i's count of j and j's of i); None where not recorded."""
    teams = race_teams(race)
    found: dict[str, int | None] = dict.fromkeys(teams, 0)
    for i, kart in enumerate(race.karts):
        for j in range(len(race.karts)):
            if teams[i] != teams[j] or j == i or (j < i and not both_ways):
                continue
            by_kart = getattr(kart, counts)
            found[teams[i]] = _add(found[teams[i]], None if by_kart is None else by_kart[j])
    return found


@dataclass(frozen=True)
class TeamPair:
    """Two teams' races against each other: each team's figures, and the mirrored pairs of races (the same seed,
    the teams' slots swapped) that both ran: those each team won once were decided by the grid, not the team."""

    first: TeamFigures
    second: TeamFigures
    mirrored_pairs: int
    split_pairs: int  # mirrored pairs won once by each team

    def to_json(self) -> dict[str, object]:
        """The pair as JSON."""
        return {
            "teams": [self.first.team, self.second.team],
            "figures": [self.first.to_json(), self.second.to_json()],
            "mirrored_pairs": self.mirrored_pairs,
            "split_pairs": self.split_pairs,
        }


def team_pairs(
    races: Sequence[RaceFigures], points: Sequence[float] = ORIGINAL_POINTS
) -> dict[frozenset[str], TeamPair]:
    """Every pair of teams that met in races of exactly two teams (races without teams are left out)."""
    grouped: dict[frozenset[str], list[RaceFigures]] = {}
    for race in races:
        if race.teams is not None and len(set(race.teams)) == 2:
            grouped.setdefault(frozenset(race.teams), []).append(race)
    found = {}
    for pair, group in grouped.items():
        first, second = dict.fromkeys(group[0].teams or ())
        figures = team_figures(group, points)
        by_seed: dict[object, list[str | None]] = {}
        for race in group:
            by_seed.setdefault(race.seed, []).append(team_result(race, points).winner)
        mirrored = [winners for seed, winners in by_seed.items() if seed is not None and len(winners) == 2]
        found[pair] = TeamPair(
            figures[first],
            figures[second],
            len(mirrored),
            sum(winners[0] is not None and winners[1] is not None and winners[0] != winners[1] for winners in mirrored),
        )
    return found
