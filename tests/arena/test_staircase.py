"""The pass-threshold staircase: on a simulated ego whose chance of passing falls with the leader's pace through
a known threshold it settles there; the real one runs attempts of the scenario's cells."""

from __future__ import annotations

import numpy as np
import pytest

from arena.scenario_spec import load_scenario
from arena.staircase import pass_staircase, staircase


@pytest.mark.parametrize("threshold", [0.93, 0.96])
def test_the_staircase_settles_at_the_pace_passed_half_the_time(threshold: float) -> None:
    """P(pass at pace r) = 1 / (1 + exp((r - threshold) / 0.005)): r50 = threshold exactly."""
    rng = np.random.default_rng(4)

    def attempt(pace: float, _i: int) -> bool:
        return bool(rng.random() < 1.0 / (1.0 + np.exp((pace - threshold) / 0.005)))

    result = staircase(attempt, start=0.99, step=0.01, trials=80)
    assert result.r50 == pytest.approx(threshold, abs=0.006)
    assert result.ci95 is not None and result.ci95.low <= result.r50 <= result.ci95.high
    assert len(result.reversals) >= 10 and len(result.paces) == 80
    # every step is one step up after a pass, one down after a failure
    for before, after, ok in zip(result.paces, result.paces[1:], result.passed, strict=False):
        assert after == pytest.approx(before + (0.01 if ok else -0.01))


def test_bad_settings_and_a_defending_scenario_are_refused() -> None:
    with pytest.raises(ValueError, match="step > 0"):
        staircase(lambda pace, i: True, start=0.95, step=0.0, trials=3)
    with pytest.raises(ValueError, match="needs an overtaking scenario"):
        pass_staircase(load_scenario("defend-straight"), "oval", "mcts-rl", "fixed-rl", 3)


def test_a_real_staircase_climbs_after_each_pass() -> None:
    """fixed-lqng behind a lane follower at pace 0.8 on the oval passes: the next leader is faster."""
    result = pass_staircase(load_scenario("overtake-straight"), "oval", "fixed-lqng", "lane-follower", 2, 0.8, 0.05)
    assert result.paces == (0.8, 0.85) and result.passed[0]
