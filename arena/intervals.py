"""95% intervals for the tournament's figures: Wilson score intervals for win rates, bootstrap intervals for
per-race means (collisions, illegal lane changes, the safety score, Δr, Δv).

* **Wilson** (``scipy.stats.binomtest(...).proportion_ci(method="wilson")``): the usual interval for a
  proportion from a few dozen trials; unlike the normal approximation it stays inside [0, 1] and is not empty at
  0 or n successes (50-0 still gets an interval: [0.93, 1]).
* **Bootstrap** (``scipy.stats.bootstrap``, percentile method, a fixed seed so that a table regenerates to the
  same digits): safety counts are small integers with long tails (a race with a 6-collision pile-up), where
  a t-interval's normality is a poor guess. Constant samples get the point interval.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats as scipy_stats

CONFIDENCE = 0.95
BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 0


@dataclass(frozen=True)
class Interval:
    """A two-sided interval ``[low, high]`` at ``confidence``."""

    low: float
    high: float
    confidence: float = CONFIDENCE

    def to_json(self) -> list[float]:
        """``[low, high]``."""
        return [self.low, self.high]

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies in the interval (ends included)."""
        return self.low <= value <= self.high


def interval_json(interval: Interval | None) -> list[float] | None:
    """``[low, high]`` of ``interval``, or None where there is none (too few samples)."""
    return None if interval is None else interval.to_json()


def wilson(successes: int, trials: int, confidence: float = CONFIDENCE) -> Interval | None:
    """The Wilson score interval of ``successes`` in ``trials`` (``None`` without trials)."""
    if trials <= 0:
        return None
    if not 0 <= successes <= trials:
        raise ValueError(f"successes must be in [0, {trials}], got {successes}")
    ci = scipy_stats.binomtest(successes, trials).proportion_ci(confidence_level=confidence, method="wilson")
    return Interval(float(ci.low), float(ci.high), confidence)


def bootstrap_mean(
    values: Sequence[float], confidence: float = CONFIDENCE, resamples: int = BOOTSTRAP_RESAMPLES
) -> Interval | None:
    """A percentile bootstrap interval of the mean of ``values`` (``None`` for fewer than two; the point interval
    for constant ones), seeded so that it regenerates exactly."""
    array = np.asarray(values, dtype=float)
    if len(array) < 2:
        return None
    if np.ptp(array) == 0.0:
        return Interval(float(array[0]), float(array[0]), confidence)
    result = scipy_stats.bootstrap(
        (array,),
        np.mean,
        confidence_level=confidence,
        n_resamples=resamples,
        method="percentile",
        rng=np.random.default_rng(BOOTSTRAP_SEED),
    )
    ci = result.confidence_interval
    return Interval(float(ci.low), float(ci.high), confidence)
