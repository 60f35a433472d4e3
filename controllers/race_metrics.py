"""Measurements of a headless race beyond the referee's result, taken step by step through
:func:`controllers.race.run_race`'s ``on_step`` hook:

* opponent prediction accuracy: for every plan a tactical driver applies, the lane it predicts for each other
  kart at that kart's next 1, 2 and 3 checkpoints, against the lane the kart then crossed them in;
* passes: overtakes completed and held for at least ``PASS_HOLD`` seconds, per kart (the order along the track
  of two karts flips, and the new order lasts; the first order after the start is no pass);
* plan lengths: the fewest ego waypoints of any applied tactical plan (no plan collapse).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from controllers.base import Controller
from controllers.hierarchical import HierarchicalController
from sim_core.observation import KartView, observe
from sim_core.params import DT
from sim_core.world import World

PASS_HOLD = 2.0  # [s]
PREDICTION_DEPTH = 3  # checkpoints ahead of the predicted kart


@dataclass
class RaceMetrics:
    """Collects the measurements of one race; pass :meth:`__call__` as ``on_step``."""

    n_karts: int
    predictions: list[tuple[int, int, int, int]] = field(default_factory=list)  # (predictor, kart, checkpoint, lane)
    crossings: dict[tuple[int, int], int] = field(default_factory=dict)  # (kart, checkpoint) -> lane crossed in
    passes: list[int] = field(default_factory=list)
    shortest_plan: dict[int, int] = field(default_factory=dict)  # tactical driver -> fewest ego waypoints
    _applied: list[int] = field(default_factory=list)
    _passed: list[int] = field(default_factory=list)
    _distance: list[float] = field(default_factory=list)
    _last_progress: list[float] = field(default_factory=list)
    _held: dict[tuple[int, int], int] = field(default_factory=dict)  # pair -> order (+1: first ahead) held
    _since: dict[tuple[int, int], tuple[int, int]] = field(default_factory=dict)  # pair -> (order, first step)

    def __post_init__(self) -> None:
        self.passes = [0] * self.n_karts
        self._applied = [0] * self.n_karts
        self._passed = [0] * self.n_karts
        self._distance = [0.0] * self.n_karts
        self._last_progress = [-1.0] * self.n_karts

    def __call__(self, world: World, drivers: Sequence[Controller], step: int) -> None:
        views = observe(world, 0)[0].karts
        length = world.track.length
        for k, view in enumerate(views):
            if view.checkpoints_passed > self._passed[k]:
                self._passed[k] = view.checkpoints_passed
                self.crossings[(k, view.checkpoints_passed)] = view.lane
            if self._last_progress[k] >= 0.0:
                delta = (view.progress - self._last_progress[k] + 0.5 * length) % length - 0.5 * length
                self._distance[k] += delta
            self._last_progress[k] = view.progress
            driver = drivers[k]
            if isinstance(driver, HierarchicalController) and driver.plans_applied != self._applied[k]:
                self._applied[k] = driver.plans_applied
                plan = driver.active_plan
                if plan is not None and plan.iterations > 0:
                    ego = len(plan.ego_waypoints)
                    self.shortest_plan[k] = min(self.shortest_plan.get(k, ego), ego)
                    for other, waypoints in plan.opponent_waypoints().items():
                        ahead = views[other].checkpoints_passed
                        for w in waypoints:
                            if ahead < w.checkpoint <= ahead + PREDICTION_DEPTH:
                                self.predictions.append((k, other, w.checkpoint, w.lane))
        self._count_passes(views, step)

    def _count_passes(self, views: Sequence[KartView], step: int) -> None:
        hold = round(PASS_HOLD / DT)
        for a in range(self.n_karts):
            for b in range(a + 1, self.n_karts):
                if views[a].finished or views[b].finished:
                    continue
                order = 1 if self._distance[a] > self._distance[b] else -1
                pair = (a, b)
                current, first = self._since.get(pair, (0, step))
                if order != current:
                    self._since[pair] = (order, step)
                    continue
                if step - first >= hold and self._held.get(pair) != order:
                    if pair in self._held:
                        self.passes[a if order == 1 else b] += 1
                    self._held[pair] = order

    def prediction_hits(self) -> tuple[int, int]:
        """(right, judged) opponent lane predictions (those whose checkpoint the kart reached)."""
        right = judged = 0
        for _, kart, checkpoint, lane in self.predictions:
            actual = self.crossings.get((kart, checkpoint))
            if actual is not None:
                judged += 1
                right += int(actual == lane)
        return right, judged
