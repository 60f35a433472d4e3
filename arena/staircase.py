"""The pass threshold by a staircase, as the Indy Autonomous Challenge's passing contest raised the defender's
speed step by step: after a pass the next attempt's leader is faster by ``step``, after a failure slower. A
one-up-one-down staircase settles around the pace at which the ego passes in half the attempts (r50; Levitt's
transformed up-down methods); its estimate is the mean pace of the reversals after the first two, with a
bootstrap interval over those reversals.

It spends attempts where they tell most, near the threshold, where a fixed ladder
(:func:`arena.scenarios.pass_thresholds`) spends most of them far from it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from arena.intervals import Interval, bootstrap_mean
from arena.scenario_setups import attempt_specs, judge
from arena.scenario_spec import Cell, Scenario
from controllers.race import run_race
from sim_core import state as st
from sim_core.params import MIN_PACE
from sim_core.world import World

SKIPPED_REVERSALS = 2  # the first reversals still carry the start's bias


@dataclass(frozen=True)
class Staircase:
    """A finished staircase: every trial's pace and outcome, the reversals and the r50 estimate."""

    paces: tuple[float, ...]
    passed: tuple[bool, ...]
    reversals: tuple[float, ...]  # the paces at which the outcome turned
    r50: float | None  # mean of the reversals after the first two (None: too few)
    ci95: Interval | None

    def to_json(self) -> dict[str, Any]:
        """Plain data: the trials, reversals, r50 and its interval."""
        return {
            "trials": [{"pace": p, "passed": ok} for p, ok in zip(self.paces, self.passed, strict=True)],
            "reversals": list(self.reversals),
            "r50": self.r50,
            "ci95": None if self.ci95 is None else [self.ci95.low, self.ci95.high],
        }


def staircase(
    attempt: Callable[[float, int], bool], start: float, step: float, trials: int, top: float = 1.0
) -> Staircase:
    """Run ``trials`` trials: ``attempt(pace, i)`` says whether trial ``i`` at leader pace ``pace`` passed; the pace
    goes up ``step`` after a pass and down after a failure, within [``MIN_PACE``, ``top``]."""
    if not MIN_PACE <= start <= top or step <= 0.0 or trials < 1:
        raise ValueError(f"need MIN_PACE <= start <= top, step > 0, trials >= 1; got {start}, {step}, {trials}")
    pace, paces, passed = start, [], []
    for i in range(trials):
        ok = attempt(pace, i)
        paces.append(pace)
        passed.append(ok)
        # rounded to the step's grid: a long staircase does not drift by floating-point sums
        pace = round(min(top, pace + step) if ok else max(MIN_PACE, pace - step), 6)
    reversals = [paces[i] for i in range(1, len(paces)) if passed[i] != passed[i - 1]]
    counted = reversals[SKIPPED_REVERSALS:]
    r50 = sum(counted) / len(counted) if counted else None
    return Staircase(tuple(paces), tuple(passed), tuple(reversals), r50, bootstrap_mean(counted))


def pass_staircase(
    scenario: Scenario,
    track: str,
    ego: str,
    opponent: str,
    trials: int,
    start: float = 0.95,
    step: float = 0.01,
    seed: int = 0,
) -> Staircase:
    """The overtaking staircase of ``ego`` behind ``opponent`` on ``track``: trial ``i`` is attempt ``i`` of the
    scenario's cell at that trial's leader pace (its own seed, gap and conditions)."""
    if scenario.kind != "overtake":
        raise ValueError(f"a pass staircase needs an overtaking scenario, {scenario.name!r} is {scenario.kind!r}")

    def attempt(pace: float, i: int) -> bool:
        (spec,) = attempt_specs(scenario, Cell(scenario.name, track, ego, opponent, pace), 1, seed, first=i)
        first: list[int] = []

        def note(world: World, _drivers: object, step_: int) -> None:
            if not first and world.istate[0, 0, st.I_PASSES] > 0:
                first.append(step_)

        outcome = run_race(spec, on_step=note)
        return judge(scenario.kind, outcome, first[0] if first else None).success

    return staircase(attempt, start, step, trials)
