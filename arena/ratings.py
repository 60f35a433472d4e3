"""Ratings of every agent from every race of a tournament: a Plackett-Luce fit of the finishing orders, with
bootstrap intervals.

Why Plackett-Luce (fitted by ``choix``) rather than ``openskill``: a tournament is a fixed set of races, not a
stream, and the maximum-likelihood fit uses all of them at once, whatever order they ran in (an online rating
such as openskill's depends on the order its updates come in, and its uncertainty is a prior's, not a sampling
interval). Plackett-Luce is Bradley-Terry for two karts and ranks the karts of races of any size.

A race's finishing order (:func:`finishing_order`) is the finishers by time, then every kart that did not finish,
unordered among themselves: in Plackett-Luce terms the winner is chosen from all karts, the second from the rest,
and so on down the finishers (``choix``'s "top-1" data: each finisher against the karts behind it). Karts of
the same agent in one race are one player and are not compared with each other; a race nobody finished tells
nothing. A small ridge (``REGULARISATION``) keeps the fit finite when an agent won every race it ran.

A rating is the agent's log-strength ``theta``, centred to mean 0: agent a beats agent b with probability
``1 / (1 + exp(theta_b - theta_a))``. Intervals: percentile bootstrap over races (resampled with replacement,
a fixed seed).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import choix
import numpy as np

from arena.intervals import CONFIDENCE, Interval
from arena.records import RaceFigures

REGULARISATION = 0.01  # choix's alpha: a weak prior toward equal strengths
BOOTSTRAP_RESAMPLES = 500
BOOTSTRAP_SEED = 0

Choice = tuple[int, tuple[int, ...]]  # (winner, the agents it was chosen over)


@dataclass(frozen=True)
class Rating:
    """One agent's rating: its centred log-strength, its interval, and how many races it ran."""

    agent: str
    theta: float
    ci95: Interval | None
    races: int

    def to_json(self) -> dict[str, Any]:
        """``{"agent", "theta", "ci95": [low, high] | None, "races"}``."""
        return {
            "agent": self.agent,
            "theta": self.theta,
            "ci95": self.ci95.to_json() if self.ci95 else None,
            "races": self.races,
        }


def finishing_order(race: RaceFigures) -> tuple[list[str], list[str]]:
    """(the finishers' agents by finishing time, the agents of karts that did not finish)."""
    finishers = sorted((k.total_time, i) for i, k in enumerate(race.karts) if k.finished and k.total_time is not None)
    finished = {i for _, i in finishers}
    return [race.karts[i].agent for _, i in finishers], [k.agent for i, k in enumerate(race.karts) if i not in finished]


def race_choices(race: RaceFigures, index: dict[str, int]) -> list[Choice]:
    """The race's Plackett-Luce choices: each finisher chosen over every kart behind it (other agents only)."""
    finishers, rest = finishing_order(race)
    choices = []
    for place, agent in enumerate(finishers):
        behind = {index[a] for a in (*finishers[place + 1 :], *rest) if a != agent}
        if behind:
            choices.append((index[agent], tuple(sorted(behind))))
    return choices


def _fit(n_agents: int, choices: list[Choice]) -> np.ndarray:
    """The centred log-strengths of ``choices``: races of two karts only (every choice over one kart) as a
    matrix of pairwise counts, ``choix.ilsr_pairwise_dense``, whose cost does not grow with the races (a thousand
    races fit in a millisecond, not thirty); the general case by ``choix.ilsr_top1``. Both are the same
    likelihood, fitted by the same iteration."""
    if not choices:
        return np.zeros(n_agents)
    if all(len(losers) == 1 for _, losers in choices):
        counts = np.zeros((n_agents, n_agents))
        np.add.at(counts, ([w for w, _ in choices], [losers[0] for _, losers in choices]), 1.0)
        theta = np.asarray(choix.ilsr_pairwise_dense(counts, alpha=REGULARISATION), dtype=float)
    else:
        theta = np.asarray(choix.ilsr_top1(n_agents, choices, alpha=REGULARISATION), dtype=float)
    return theta - theta.mean()


def ratings(races: Sequence[RaceFigures], resamples: int = BOOTSTRAP_RESAMPLES) -> list[Rating]:
    """Every agent's rating from ``races``, best first (see the module notes); intervals from ``resamples``
    bootstrap fits (none below 2 races)."""
    agents = sorted({agent for race in races for agent in race.agents})
    if len(agents) < 2:
        return [Rating(a, 0.0, None, sum(a in r.agents for r in races)) for a in agents]
    index = {agent: i for i, agent in enumerate(agents)}
    per_race = [race_choices(race, index) for race in races]
    theta = _fit(len(agents), [c for choices in per_race for c in choices])
    intervals: list[Interval | None] = [None] * len(agents)
    if len(races) >= 2 and resamples > 0:
        rng = np.random.default_rng(BOOTSTRAP_SEED)
        samples = np.empty((resamples, len(agents)))
        for b in range(resamples):
            drawn = rng.integers(0, len(races), len(races))
            samples[b] = _fit(len(agents), [c for r in drawn for c in per_race[r]])
        tail = (1.0 - CONFIDENCE) / 2.0 * 100.0
        low, high = np.percentile(samples, [tail, 100.0 - tail], axis=0)
        intervals = [Interval(float(lo), float(hi)) for lo, hi in zip(low, high, strict=True)]
    result = [
        Rating(agent, float(theta[i]), intervals[i], sum(agent in race.agents for race in races))
        for agent, i in index.items()
    ]
    return sorted(result, key=lambda r: (-r.theta, r.agent))


def win_probability(a: Rating, b: Rating) -> float:
    """The fitted probability that ``a`` finishes ahead of ``b`` in a race of the two."""
    return float(1.0 / (1.0 + np.exp(b.theta - a.theta)))
