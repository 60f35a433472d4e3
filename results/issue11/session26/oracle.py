"""An oracle for issue 11's lane-2 start on `complex`: mcts-lqng's own tracker (as registered) driven through lanes
chosen by hand or by search, with perfect knowledge of the other kart (fixed-lqng replays its racing line, so its
future lanes are known exactly), against fixed-lqng as registered.

Whatever lanes a discrete lane/checkpoint planner sends, its kart drives them with this tracker. If no lane
sequence wins from lane 2, no planner of the paper's structure over this tracker can; if one does, it is the
manoeuvre the planner has to find.

Races are deterministic. A race can be snapshotted (deep copy of the world and both drivers) and continued with
other lanes, so a window of lanes can be searched from the moment just before it matters.
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass, replace

import numpy as np

from controllers.base import RaceContext
from controllers.fixed_line import FixedLinePlanner
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import CLOSE_FOLLOWING_TRACKING, FIXED_LINE_TRACKING, LQNGTracker
from controllers.plan import Plan, Waypoint
from controllers.registry import make_controller
from sim_core import state as st
from sim_core.observation import Observation, observe
from sim_core.params import SimParams, kart_preset
from sim_core.track import Track
from sim_core.track_io import get_track
from sim_core.world import World


class ScriptedLanePlanner:
    """Ego lanes from ``lanes`` (absolute checkpoint -> lane), the racing line's elsewhere; the other karts
    predicted on the racing line (what fixed-lqng drives)."""

    def __init__(self, lanes: dict[int, int] | None = None, horizon: int = 8, rate_hz: float = 5.0) -> None:
        self.lanes = dict(lanes or {})
        self.horizon = horizon
        self.rate_hz = rate_hz
        self._line_planner = FixedLinePlanner(horizon=horizon)
        self._track: Track | None = None

    def reset(self, context: RaceContext) -> None:
        self._line_planner.reset(context)
        self._track = context.track

    def line_lane(self, checkpoint: int) -> int:
        assert self._track is not None
        return int(self._line_planner.line.checkpoint_lanes[checkpoint % self._track.n_checkpoints])

    def _waypoints(self, first: int, lanes: dict[int, int]) -> tuple[Waypoint, ...]:
        assert self._track is not None
        track, line = self._track, self._line_planner.line
        out = []
        for checkpoint in range(first, first + self.horizon):
            c = checkpoint % track.n_checkpoints
            lane = lanes.get(checkpoint, self.line_lane(checkpoint))
            point = track.lane_point(c, lane)
            speed = float(np.interp(track.checkpoint_s[c], line.s, line.speed, period=track.length))
            out.append(Waypoint(checkpoint, lane, (float(point[0]), float(point[1])), speed, 0.0))
        return tuple(out)

    def plan(self, observation: Observation) -> Plan:
        waypoints = {}
        for k in observation.karts:
            first = max(k.checkpoints_passed, 0) + 1
            waypoints[k.index] = self._waypoints(first, self.lanes if k.index == observation.ego else {})
        return Plan(observation.ego, observation.me.checkpoints_passed, waypoints, 0, 0, 0.0)


def oracle_driver(lanes: dict[int, int] | None = None, **tracking: float) -> HierarchicalController:
    """mcts-lqng's tracker as registered, on scripted lanes (``tracking`` overrides LQNGParams fields)."""
    return HierarchicalController(
        "oracle", ScriptedLanePlanner(lanes), LQNGTracker(replace(CLOSE_FOLLOWING_TRACKING, **tracking))
    )


@dataclass
class RaceState:
    """A race in progress: the world, its drivers, the step count."""

    world: World
    drivers: list[HierarchicalController]
    step: int = 0

    def fork(self) -> RaceState:
        memo = {id(self.world.track): self.world.track}
        return copy.deepcopy(self, memo)

    @property
    def done(self) -> bool:
        return bool(self.world.done[0])

    def advance(self) -> None:
        """One 0.02 s step, every driver acting (as controllers.race.run_race, no launch delays)."""
        observations = observe(self.world, 0)
        actions = np.zeros((1, len(self.drivers), 2))
        for k, driver in enumerate(self.drivers):
            if observations[k].me.finished:
                continue
            action = driver.act(observations[k])
            actions[0, k] = (action.steer, action.throttle)
        self.world.step(actions)
        self.step += 1

    def checkpoints(self, kart: int) -> int:
        return int(self.world.istate[0, kart, st.I_CP_PASSED])

    def gap(self) -> float:
        """Kart 0's total progress minus kart 1's [m] (positive: kart 0 ahead; 0 alone)."""
        progress = self.world.total_progress()[0]
        return float(progress[0] - progress[1]) if len(progress) > 1 else 0.0


def fixed_on_lanes(lanes: dict[int, int]) -> HierarchicalController:
    """fixed-lqng's tracker as registered, on the racing line with ``lanes`` (absolute checkpoint -> lane) in place
    of the line's own lanes: a fixed line, planned offline."""
    return HierarchicalController("fixed-on-lanes", ScriptedLanePlanner(lanes), LQNGTracker(FIXED_LINE_TRACKING))


def load_lanes(path: str) -> dict[int, int]:
    """The committed lanes of an mpc.py run (its JSON)."""
    with open(path) as fh:
        return {int(k): int(v) for k, v in json.load(fh)["summary"]["lanes"].items()}


def start_race(
    track_name: str,
    ego: HierarchicalController,
    start_lanes: tuple[int, ...] = (2, 3),
    seed: int = 0,
    opponent: str | HierarchicalController | None = "fixed-lqng",
) -> RaceState:
    """kart 0 = ``ego``, kart 1 = ``opponent`` (a registered name or a driver; None: the ego races alone), on the
    grid, not yet stepped."""
    track = get_track(track_name)
    params = SimParams(kart=kart_preset("paper"))
    drivers = [ego]
    if opponent is not None:
        drivers.append(make_controller(opponent) if isinstance(opponent, str) else opponent)
    world = World(track, 1, len(drivers), params)
    world.reset(start_lanes=start_lanes[: len(drivers)])
    for k, driver in enumerate(drivers):
        driver.plan_latency = 0.1
        driver.reset(RaceContext(track, params.kart, k, len(drivers), world.lane_change_limit, seed * 1000 + k))
    return RaceState(world, drivers)  # type: ignore[arg-type]


def finish(state: RaceState) -> dict[str, object]:
    """Run ``state`` to the end; the referee's figures for both karts."""
    while not state.done:
        state.advance()
    result = state.world.result(0)
    karts = result.karts
    return {
        "winner": result.winner,
        "time": tuple(k.finish_time for k in karts),
        "faults": tuple(k.collisions_at_fault for k in karts),
        "illegal": tuple(k.illegal_lane_changes for k in karts),
        "passes": tuple(k.passes for k in karts),
    }


def margin(outcome: dict[str, object]) -> float:
    """Seconds kart 0 finished ahead (negative: behind; alone: minus its finish time)."""
    times = outcome["time"]  # type: ignore[assignment]
    t0, t1 = (times[0], 0.0) if len(times) == 1 else times  # type: ignore[arg-type]
    return (math.inf if t1 is None else t1) - (math.inf if t0 is None else t0)
