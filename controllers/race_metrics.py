"""Measurements of a headless race beyond the referee's result, taken step by step through
:func:`controllers.race.run_race`'s ``on_step`` hook:

* opponent prediction accuracy: for every plan a tactical driver applies, the lane it predicts for each other
  kart at that kart's next 1, 2 and 3 checkpoints, against the lane the kart then crossed them in;
* plan lengths: the fewest ego waypoints of any applied tactical plan, padding not counted (no plan collapse).

Passes are the referee's (``KartResult.passes``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from controllers.base import Controller, PlanningDriver
from sim_core.observation import observe
from sim_core.world import World

PREDICTION_DEPTH = 3  # checkpoints ahead of the predicted kart


@dataclass
class RaceMetrics:
    """Collects the measurements of one race; pass :meth:`__call__` as ``on_step``."""

    n_karts: int
    predictions: list[tuple[int, int, int, int]] = field(default_factory=list)  # (predictor, kart, checkpoint, lane)
    crossings: dict[tuple[int, int], int] = field(default_factory=dict)  # (kart, checkpoint) -> lane crossed in
    shortest_plan: dict[int, int] = field(default_factory=dict)  # tactical driver -> fewest ego waypoints
    _applied: list[int] = field(default_factory=list)
    _passed: list[int] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._applied = [0] * self.n_karts
        self._passed = [0] * self.n_karts

    def __call__(self, world: World, drivers: Sequence[Controller], step: int) -> None:
        views = observe(world, 0)[0].karts
        for k, view in enumerate(views):
            if view.checkpoints_passed > self._passed[k]:
                self._passed[k] = view.checkpoints_passed
                self.crossings[(k, view.checkpoints_passed)] = view.lane
            driver = drivers[k]
            if isinstance(driver, PlanningDriver) and driver.plans_applied != self._applied[k]:
                self._applied[k] = driver.plans_applied
                plan = driver.active_plan
                if plan is not None and plan.iterations > 0:
                    ego = len(plan.ego_waypoints) - plan.padded  # padding is not a plan
                    self.shortest_plan[k] = min(self.shortest_plan.get(k, ego), ego)
                    for other, waypoints in plan.opponent_waypoints().items():
                        ahead = views[other].checkpoints_passed
                        for w in waypoints:
                            if ahead < w.checkpoint <= ahead + PREDICTION_DEPTH:
                                self.predictions.append((k, other, w.checkpoint, w.lane))

    def prediction_hits(self) -> tuple[int, int]:
        """(right, judged) opponent lane predictions (those whose checkpoint the kart reached)."""
        right = judged = 0
        for _, kart, checkpoint, lane in self.predictions:
            actual = self.crossings.get((kart, checkpoint))
            if actual is not None:
                judged += 1
                right += int(actual == lane)
        return right, judged
