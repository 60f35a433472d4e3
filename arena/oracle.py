"""The oracle bound of a scenario cell: the best a lane-choosing planner could do on each attempt.

A lane-choosing planner decides which lane its tracker drives at the coming checkpoints. The oracle makes that
choice with what no planner has: the simulator itself and the opponent's own controller. Once a second
(``replan_s``) it copies the race (:meth:`sim_core.world.World.state_arrays`) and both drivers, and races each
candidate forward for ``lookahead_s``: the racing line, and each lane held for the next ``hold_checkpoints``
checkpoints before rejoining the line. The candidate that ends furthest ahead of the opponent (along the track)
with no collision at fault and no illegal lane change is the plan the ego's tracker (``fixed-lqng``'s LQ
tracker) then drives. The branches race without the drivers' imprecision (the race itself keeps it), so the
oracle's forecast is exact only up to that noise.

It is a receding-horizon search, not a proof of optimality: a pass that needs more than ``lookahead_s`` to pay
off is out of its sight. It bounds what the tactical agents' lane choices can achieve against that opponent on
those attempts; the suite's figures of the oracle sit beside theirs (``karting scenarios oracle``).
"""

from __future__ import annotations

import copy
import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from arena.scenarios import Attempt, Cell, CellFigures, Scenario, attempt_specs, judge
from arena.tournament import start_method
from controllers.base import Controller, RaceContext
from controllers.fixed_line import FixedLinePlanner
from controllers.hierarchical import HierarchicalController
from controllers.lq.presets import fixed_line_tracker
from controllers.plan import Plan, Waypoint
from controllers.race import decide, run_race
from controllers.registry import make_agent
from sim_core import state as st
from sim_core.observation import Observation, observe
from sim_core.params import DT
from sim_core.world import World

ORACLE = "oracle"  # the ego's name in the oracle's figures
AT_FAULT_COST = (
    1.0e3  # [m] a branch with a collision at fault or an illegal lane change is never chosen over one without
)


@dataclass(frozen=True)
class OracleSettings:
    """How far and how often the oracle looks."""

    lookahead_s: float = 4.0  # [s] how long each candidate is raced forward
    replan_s: float = 1.0  # [s] between searches (the tactical planners' rate)
    hold_checkpoints: int = 4  # checkpoints a candidate holds its lane before rejoining the line


class OraclePlanner:
    """The ego's high level: the plan the oracle chose last, else the racing line (:class:`FixedLinePlanner`)."""

    def __init__(self, rate_hz: float = 10.0) -> None:
        self.rate_hz = rate_hz  # re-read often: a new choice reaches the tracker within a tenth of a second
        self.line = FixedLinePlanner()
        self.chosen: Plan | None = None
        self._context: RaceContext | None = None

    def reset(self, context: RaceContext) -> None:
        """Optimise the racing line; forget any choice."""
        self.line.reset(context)
        self._context = context
        self.chosen = None

    def plan(self, observation: Observation) -> Plan:
        """The oracle's choice while it still has a waypoint ahead of the kart, else the line's plan."""
        passed = observation.me.checkpoints_passed
        if self.chosen is not None and any(w.checkpoint > passed for w in self.chosen.ego_waypoints):
            ahead = tuple(w for w in self.chosen.ego_waypoints if w.checkpoint > passed)
            return replace(self.chosen, waypoints={observation.ego: ahead})
        return self.line.plan(observation)

    def candidates(self, observation: Observation, hold: int) -> list[Plan]:
        """The line's plan, then for each lane the plan that holds it for ``hold`` checkpoints."""
        assert self._context is not None, "reset() first"
        track = self._context.track
        line = self.line.plan(observation)
        plans = [line]
        waypoints = line.ego_waypoints
        for lane in range(1, track.n_lanes + 1):
            held = []
            for i, w in enumerate(waypoints):
                if i < hold:
                    point = track.lane_point(w.checkpoint, lane)
                    w = Waypoint(w.checkpoint, lane, (float(point[0]), float(point[1])), w.speed, w.time)
                held.append(w)
            if any(a.lane != b.lane for a, b in zip(held, waypoints, strict=True)):
                plans.append(replace(line, waypoints={observation.ego: tuple(held)}))
        return plans


def oracle_driver() -> HierarchicalController:
    """The ego the oracle steers: its planner holds the oracle's choice, ``fixed-lqng``'s tracker drives it."""
    return HierarchicalController(ORACLE, OraclePlanner(), fixed_line_tracker(4), plan_latency=0.0)


class LaneOracle:
    """The search, run as a one-race step hook (it sees the world and the drivers); it also notes the step of the
    ego's first pass (:func:`arena.scenarios.judge`)."""

    def __init__(self, settings: OracleSettings) -> None:
        self.settings = settings
        self.searches = 0
        self.off_line = 0  # searches that chose a lane off the racing line
        self.first_pass_step: int | None = None

    def __call__(self, world: World, drivers: Sequence[Controller], step: int) -> None:
        """Search when due and hand the ego's planner the best candidate."""
        race = 0
        if self.first_pass_step is None and world.istate[race, 0, st.I_PASSES] > 0:
            self.first_pass_step = step
        every = max(1, round(self.settings.replan_s / DT))
        if step % every or world.istate[race, 0, st.I_FINISHED]:
            return
        ego = drivers[0]
        assert isinstance(ego, HierarchicalController) and isinstance(ego.planner, OraclePlanner)
        observation = observe(world, race)[0]
        candidates = ego.planner.candidates(observation, self.settings.hold_checkpoints)
        saved = world.state_arrays()
        scores = [self._race_forward(world, race, saved, drivers, plan) for plan in candidates]
        best = int(np.argmax(scores))  # the first of equals: the line's
        ego.planner.chosen = candidates[best]
        self.searches += 1
        self.off_line += best > 0

    def _race_forward(
        self, world: World, race: int, saved: dict[str, np.ndarray], drivers: Sequence[Controller], plan: Plan
    ) -> float:
        """[m] how far ahead of the opponent the ego ends driving ``plan`` for the lookahead (less
        :data:`AT_FAULT_COST` for a collision at fault or an illegal lane change on the way)."""
        branch = World(world.track, 1, world.n_karts, world.params, laps=world.laps, sensors=world.sensors)
        branch.kart_rows[0] = world.kart_rows[race]
        branch.paces[0] = world.paces[race]
        branch.restore_state({name: array[race : race + 1] for name, array in saved.items()})
        karts: list[Any] = [copy.deepcopy(d) for d in drivers]
        ego = karts[0]
        ego.deliver(plan)
        ego.planner.chosen = plan
        before = branch.istate[0, 0, [st.I_FAULTS, st.I_ILLEGAL]].copy()
        holds = [max(1, round(1.0 / (DT * d.rate_hz))) for d in karts]
        actions = np.zeros((1, world.n_karts, 2))
        for step in range(round(self.settings.lookahead_s / DT)):
            observations = observe(branch, 0)
            due = [k for k in range(world.n_karts) if step % holds[k] == 0]
            for k, action in zip(due, decide([karts[k] for k in due], [observations[k] for k in due]), strict=True):
                actions[0, k] = (action.steer, action.throttle)
            branch.step(actions)
            if branch.done[0]:
                break
        progress = branch.total_progress()[0]
        faults = branch.istate[0, 0, [st.I_FAULTS, st.I_ILLEGAL]] - before
        return float(progress[0] - progress[1]) - AT_FAULT_COST * float(faults.sum())


def run_oracle_cell(scenario: Scenario, cell: Cell, attempts: int, seed: int, settings: OracleSettings) -> CellFigures:
    """The oracle's figures on ``cell``'s attempts (the races of :func:`arena.scenarios.run_cells`)."""
    results: list[Attempt] = []
    for spec in attempt_specs(scenario, replace(cell, ego="fixed-lqng"), attempts, seed):
        oracle = LaneOracle(settings)
        drivers = [oracle_driver(), make_agent(spec.controllers[1])]
        outcome = run_race(spec, on_step=oracle, drivers=drivers)
        results.append(judge(scenario.kind, outcome, oracle.first_pass_step))
    return CellFigures.of(replace(cell, ego=ORACLE), results)


def run_oracle_cells(
    scenario: Scenario,
    cells: Sequence[Cell],
    attempts: int,
    seed: int = 0,
    settings: OracleSettings | None = None,
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> list[CellFigures]:
    """The oracle's figures on every cell (one worker process per cell with ``workers`` above 1)."""
    settings = settings or OracleSettings()
    if workers <= 1 or len(cells) <= 1:
        out = []
        for i, cell in enumerate(cells):
            out.append(run_oracle_cell(scenario, cell, attempts, seed, settings))
            if progress is not None:
                progress((i + 1) * attempts, len(cells) * attempts)
        return out
    context = multiprocessing.get_context(start_method())
    with ProcessPoolExecutor(min(workers, len(cells)), mp_context=context) as pool:  # type: ignore[arg-type]
        futures = [pool.submit(run_oracle_cell, scenario, cell, attempts, seed, settings) for cell in cells]
        return [f.result() for f in futures]
