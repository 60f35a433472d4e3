"""The intervals (:mod:`arena.intervals`) and ratings (:mod:`arena.ratings`) against hand-computed cases and an
independent fit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

from arena.intervals import bootstrap_mean, wilson
from arena.ratings import finishing_order, ratings, win_probability
from arena.records import KartFigures, RaceFigures

Z = 1.959963984540054  # the normal quantile of 0.975


def hand_wilson(k: int, n: int) -> tuple[float, float]:
    """The Wilson score interval written out."""
    p = k / n
    centre = (p + Z * Z / (2 * n)) / (1 + Z * Z / n)
    half = Z / (1 + Z * Z / n) * math.sqrt(p * (1 - p) / n + Z * Z / (4 * n * n))
    return centre - half, centre + half


def test_wilson_intervals_match_the_hand_computed_ones() -> None:
    interval = wilson(8, 10)
    assert interval is not None
    assert (interval.low, interval.high) == pytest.approx((0.4902, 0.9433), abs=1e-4)
    clean_sweep = wilson(50, 50)
    assert clean_sweep is not None and clean_sweep.high == pytest.approx(1.0)
    assert clean_sweep.low == pytest.approx(50 / (50 + Z * Z))  # n / (n + z^2) at n successes
    assert wilson(0, 0) is None
    with pytest.raises(ValueError, match="successes"):
        wilson(11, 10)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 400), data=st.data())
def test_wilson_is_the_formula_and_contains_the_observed_rate(n: int, data: st.DataObject) -> None:
    k = data.draw(st.integers(0, n))
    interval = wilson(k, n)
    assert interval is not None
    assert (interval.low, interval.high) == pytest.approx(hand_wilson(k, n), abs=1e-9)
    assert 0.0 <= interval.low <= k / n <= interval.high <= 1.0


def test_a_bootstrap_interval_of_the_mean_covers_it_and_narrows_with_samples() -> None:
    rng = np.random.default_rng(3)
    few, many = rng.poisson(1.5, 30), rng.poisson(1.5, 600)
    narrow, wide = bootstrap_mean(many), bootstrap_mean(few)
    assert narrow is not None and wide is not None
    assert wide.contains(float(few.mean())) and narrow.contains(float(many.mean()))
    assert narrow.high - narrow.low < wide.high - wide.low
    # the normal approximation's half-width for many samples: the bootstrap agrees within a tenth
    half = Z * many.std(ddof=1) / math.sqrt(len(many))
    assert (narrow.high - narrow.low) / 2 == pytest.approx(half, rel=0.1)
    assert bootstrap_mean([2.0, 2.0, 2.0]) is not None and bootstrap_mean([2.0, 2.0, 2.0]).to_json() == [2.0, 2.0]  # type: ignore[union-attr]
    assert bootstrap_mean([1.0]) is None
    assert bootstrap_mean(list(few)) == wide  # seeded: a table regenerates to the same digits


def kart(agent: str, time: float | None) -> KartFigures:
    return KartFigures(agent, time is not None, time, 0, {"per_step": 0}, "per_step")


def race(*karts: tuple[str, float | None]) -> RaceFigures:
    return RaceFigures("oval", tuple(kart(a, t) for a, t in karts))


def test_two_agents_get_the_bradley_terry_fit() -> None:
    races = [race(("a", 60.0), ("b", 61.0))] * 30 + [race(("a", 62.0), ("b", 61.0))] * 10
    fitted = {r.agent: r for r in ratings(races, resamples=50)}
    # the maximum-likelihood log-odds: ln(30 / 10) (the ridge moves it by less than a percent)
    assert fitted["a"].theta - fitted["b"].theta == pytest.approx(math.log(3.0), rel=0.01)
    assert win_probability(fitted["a"], fitted["b"]) == pytest.approx(0.75, abs=0.005)
    assert fitted["a"].ci95 is not None and fitted["a"].ci95.contains(fitted["a"].theta)
    assert fitted["a"].races == 40


def plackett_luce_fit(orders: list[list[int]], n: int) -> np.ndarray:
    """An independent maximum-likelihood Plackett-Luce fit (scipy.optimize) of complete orders."""

    def negative_log_likelihood(theta: np.ndarray) -> float:
        total = 0.0
        for order in orders:
            for place in range(len(order) - 1):
                rest = theta[order[place:]]
                total -= theta[order[place]] - np.log(np.exp(rest).sum())
        return total + 0.5 * 1e-9 * float(theta @ theta)

    found = minimize(negative_log_likelihood, np.zeros(n), method="BFGS").x
    return found - found.mean()


def test_races_of_three_karts_get_the_plackett_luce_fit() -> None:
    rng = np.random.default_rng(5)
    truth = np.array([1.0, 0.0, -0.7])
    orders = []
    for _ in range(300):
        weights = np.exp(truth)
        left, order = [0, 1, 2], []
        while left:
            pick = rng.choice(left, p=weights[left] / weights[left].sum())
            order.append(int(pick))
            left.remove(pick)
        orders.append(order)
    names = ["a", "b", "c"]
    races = [race(*((names[k], 60.0 + place) for place, k in enumerate(order))) for order in orders]
    fitted = {r.agent: r.theta for r in ratings(races, resamples=0)}
    expected = plackett_luce_fit(orders, 3)
    assert [fitted[n] for n in names] == pytest.approx(list(expected), abs=0.02)


def test_karts_that_did_not_finish_rank_below_every_finisher_and_unordered() -> None:
    assert finishing_order(race(("a", None), ("b", 70.0), ("c", 65.0), ("d", None))) == (["c", "b"], ["a", "d"])
    # a race nobody finished tells nothing: the same fit with or without it
    races = [race(("a", 60.0), ("b", 61.0))] * 3 + [race(("a", 61.0), ("b", 60.0))]
    with_nothing = [*races, race(("a", None), ("b", None))]
    assert [r.theta for r in ratings(races, 0)] == pytest.approx([r.theta for r in ratings(with_nothing, 0)])
