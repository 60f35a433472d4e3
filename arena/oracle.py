"""The oracle bound of a scenario cell: what a lane-choosing planner could do with the simulator's foresight.

A hierarchical agent's planner decides which lane its tracker drives at the coming checkpoints. The oracle
makes that choice with what no planner has: the simulator itself and the opponent's own controller. At each of
the base agent's plans (``mcts-lqng`` by default, once a second) it copies the race
(:meth:`sim_core.world.World.state_arrays`), its tracker and the opponent, and races candidates forward for
``lookahead_s``: the base agent's own plan, and that plan with each lane held for the next ``hold_checkpoints``
checkpoints. The candidate that ends furthest ahead of the opponent along the track, with no collision at fault
and no illegal lane change, is the plan its tracker drives (the base plan when none does better). The branches
race without the drivers' imprecision (the race itself keeps it), so the foresight is exact only up to that
noise.

It is a receding-horizon search over a few lane choices, not a proof of optimality: a pass that needs more than
``lookahead_s`` to pay off, or another sequence of lanes, is out of its sight. What it shows is how much the
base agent's lane choices leave on the table against that opponent on those attempts
(``karting scenarios oracle``).
"""

from __future__ import annotations

import copy
import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from arena.scenario_setups import Attempt, attempt_specs, judge
from arena.scenario_spec import TWO_KART_KINDS, Cell, Scenario
from arena.scenarios import CellFigures
from arena.tournament import start_method
from controllers.base import Controller, HighLevelPlanner, RaceContext
from controllers.fixed_line import FixedLinePlanner
from controllers.hierarchical import HierarchicalController
from controllers.plan import Plan, Waypoint
from controllers.race import decide, run_race
from controllers.registry import make_agent
from sim_core import state as st
from sim_core.observation import Observation, observe
from sim_core.params import DT
from sim_core.world import World

ORACLE = "oracle"  # the ego's name in the oracle's figures
# [m] a branch with a collision at fault or an illegal lane change is never chosen over one without
AT_FAULT_COST = 1.0e3


@dataclass(frozen=True)
class OracleSettings:
    """How far the oracle looks and which agent it improves on."""

    lookahead_s: float = 4.0  # [s] how long each candidate is raced forward
    hold_checkpoints: int = 4  # checkpoints a candidate holds its lane before rejoining the base plan
    base: str = "mcts-lqng"  # the hierarchical agent whose plan is the first candidate and whose tracker drives


class _FixedPlan:
    """A high level that always returns one plan (a branch's ego)."""

    rate_hz = 1.0

    def __init__(self, plan: Plan) -> None:
        self._plan = plan

    def reset(self, context: RaceContext) -> None:
        """Nothing to prepare."""

    def plan(self, observation: Observation) -> Plan:
        """The plan."""
        return self._plan


class OraclePlanner:
    """The oracle's high level: the base agent's plan, or a variant of it holding one lane for the next
    ``hold_checkpoints`` checkpoints, whichever ends furthest ahead when raced forward in a copy of the race
    (:meth:`attach` gives it the race each step)."""

    def __init__(self, base: HighLevelPlanner, settings: OracleSettings) -> None:
        self.base = base
        self.settings = settings
        self.rate_hz = base.rate_hz
        self.searches = 0
        self.off_base = 0  # searches that chose a variant over the base plan
        self._context: RaceContext | None = None
        self._race: tuple[World, Sequence[Controller]] | None = None
        self._branch: World | None = None  # one world for every branch, its state restored from the race each time

    def reset(self, context: RaceContext) -> None:
        """Reset the base planner."""
        self.base.reset(context)
        self._context = context
        self._race = None

    def attach(self, world: World, drivers: Sequence[Controller]) -> None:
        """The race as it stands (one race, the ego kart 0)."""
        self._race = (world, drivers)

    def candidates(self, observation: Observation, base: Plan) -> list[Plan]:
        """``base``, then for each lane the plan that holds it for the first ``hold_checkpoints`` waypoints."""
        assert self._context is not None, "reset() first"
        track = self._context.track
        hold = self.settings.hold_checkpoints
        waypoints = base.ego_waypoints
        plans = [base]
        for lane in range(1, track.n_lanes + 1):
            held = []
            for i, w in enumerate(waypoints):
                if i < hold:
                    point = track.lane_point(w.checkpoint, lane)
                    w = Waypoint(w.checkpoint, lane, (float(point[0]), float(point[1])), w.speed, w.time)
                held.append(w)
            if any(a.lane != b.lane for a, b in zip(held, waypoints, strict=True)):
                plans.append(replace(base, waypoints={**base.waypoints, observation.ego: tuple(held)}))
        return plans

    def plan(self, observation: Observation) -> Plan:
        """The best candidate raced forward (the base plan alone before the race is attached)."""
        base = self.base.plan(observation)
        if self._race is None:
            return base
        world, drivers = self._race
        candidates = self.candidates(observation, base)
        saved = world.state_arrays()
        scores = [self._race_forward(world, saved, drivers, plan) for plan in candidates]
        best = int(np.argmax(scores))  # the first of equals: the base plan
        self.searches += 1
        self.off_base += best > 0
        return candidates[best]

    def _race_forward(
        self, world: World, saved: dict[str, np.ndarray], drivers: Sequence[Controller], plan: Plan
    ) -> float:
        """[m] how far ahead of the opponent the ego ends driving ``plan`` for the lookahead (less
        :data:`AT_FAULT_COST` for a collision at fault or an illegal lane change on the way)."""
        if self._branch is None or self._branch.track is not world.track:
            self._branch = World(world.track, 1, world.n_karts, world.params, laps=world.laps, sensors=world.sensors)
        branch = self._branch
        branch.kart_rows[0] = world.kart_rows[0]
        branch.paces[0] = world.paces[0]
        branch.restore_state(saved)
        ego = drivers[0]
        assert isinstance(ego, HierarchicalController)
        mine = HierarchicalController("branch", _FixedPlan(plan), copy.deepcopy(ego.tracker), plan_latency=0.0)
        mine.rate_hz = ego.rate_hz
        mine.deliver(plan)
        karts: list[Controller] = [mine, *(copy.deepcopy(d) for d in drivers[1:])]
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


class LaneOracle:
    """A one-race step hook: hands the oracle's planner the race each step and notes the step of the ego's first
    pass (:func:`arena.scenarios.judge`)."""

    def __init__(self, planner: OraclePlanner) -> None:
        self.planner = planner
        self.first_pass_step: int | None = None

    def __call__(self, world: World, drivers: Sequence[Controller], step: int) -> None:
        """Attach the race; note a first pass."""
        self.planner.attach(world, drivers)
        if self.first_pass_step is None and world.istate[0, 0, st.I_PASSES] > 0:
            self.first_pass_step = step


def oracle_driver(settings: OracleSettings) -> tuple[HierarchicalController, LaneOracle]:
    """The ego the oracle steers (the base agent with its planner wrapped) and the hook that shows it the race."""
    driver = make_agent(settings.base)
    # a fixed-line agent is composed the same way, but its high level replays a line: it chooses no lanes to improve
    if not isinstance(driver, HierarchicalController) or isinstance(driver.planner, FixedLinePlanner):
        raise ValueError(
            f"the oracle's base must be a hierarchical agent (a tactical planner and a tracker); {settings.base} is not"
        )
    planner = OraclePlanner(driver.planner, settings)
    driver.planner = planner
    driver.name = ORACLE
    return driver, LaneOracle(planner)


def run_oracle_cell(scenario: Scenario, cell: Cell, attempts: int, seed: int, settings: OracleSettings) -> CellFigures:
    """The oracle's figures on ``cell``'s attempts (the races of :func:`arena.scenarios.run_cells`)."""
    results: list[Attempt] = []
    for spec in attempt_specs(scenario, replace(cell, ego=settings.base), attempts, seed):
        ego, hook = oracle_driver(settings)
        outcome = run_race(spec, on_step=hook, drivers=[ego, make_agent(spec.controllers[1])])
        results.append(judge(scenario.kind, outcome, hook.first_pass_step))
    return CellFigures.of(replace(cell, ego=ORACLE), results)


def check_two_karts(scenario: Scenario) -> None:
    """``ValueError`` unless ``scenario`` races the ego against one opponent (the oracle's branches race two)."""
    if scenario.kind not in TWO_KART_KINDS:
        raise ValueError(f"the oracle races two karts: {scenario.name!r} is a {scenario.kind!r} scenario")


def run_oracle_cells(
    scenario: Scenario,
    cells: Sequence[Cell],
    attempts: int,
    seed: int = 0,
    settings: OracleSettings | None = None,
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> list[CellFigures]:
    """The oracle's figures on every cell (one worker process per cell with ``workers`` above 1); ``ValueError``
    for a scenario of more than two karts (its branches race the ego against one opponent)."""
    check_two_karts(scenario)
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
