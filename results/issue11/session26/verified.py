"""Prototype (issue 11, session 26): mcts-lqng whose plan is checked in the simulator before it is sent.

The MCTS plans as registered. When another kart is ahead within ``reach`` (or alongside), a few ego lane choices
for the checkpoints after the committed next one are raced forward from the present state in a private copy of
the simulator (the ego on its own tracker, the other kart on an LQ line follower driving the lanes the plan
predicts for it); the best, if it beats the search's own plan by ``margin`` s, replaces it. Candidates: the
search's lanes, the racing line's, and each lane held for ``depth`` checkpoints.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace

from controllers.base import RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import CLOSE_FOLLOWING_TRACKING, FIXED_LINE_TRACKING, LQNGParams, LQNGTracker
from controllers.plan import Plan, Waypoint
from controllers.registry import MCTSLQNGParams
from controllers.tactical.high_level import MCTSPlanner
from sim_core import state as st
from sim_core.observation import KartView, Observation, observe
from sim_core.params import SimParams
from sim_core.world import World

PENALTY = 1000.0


@dataclass
class RolloutStats:
    plans: int = 0
    checked: int = 0
    replaced: int = 0
    rollouts: int = 0


class VerifiedPlanner:
    """An MCTS planner whose plans are checked by short simulated races (see the module note)."""

    def __init__(
        self,
        inner: MCTSPlanner,
        ego_tracking: LQNGParams,
        opponent_tracking: LQNGParams,
        depth: int = 3,
        settle: int = 2,
        reach: float = 25.0,
        margin: float = 0.05,
        max_steps: int = 450,
        exhaustive: bool = False,
    ) -> None:
        self.inner = inner
        self.rate_hz = inner.rate_hz
        self.ego_tracking = ego_tracking
        self.opponent_tracking = opponent_tracking
        self.depth = depth
        self.settle = settle
        self.reach = reach
        self.margin = margin
        self.max_steps = max_steps
        self.exhaustive = exhaustive  # every lane sequence of the window, not only the holds
        self.stats = RolloutStats()
        self.trace: list[object] | None = None
        self._context: RaceContext | None = None
        self._world: World | None = None
        self._trackers: tuple[LQNGTracker, LQNGTracker] | None = None

    def reset(self, context: RaceContext) -> None:
        self.inner.reset(context)
        self._context = context
        params = SimParams(kart=context.kart)
        self._world = World(context.track, 1, 2, params, sensors=False)
        ego, other = LQNGTracker(self.ego_tracking), LQNGTracker(self.opponent_tracking)
        ego.reset(RaceContext(context.track, context.kart, 0, 2, context.lane_change_limit, context.seed))
        other.reset(RaceContext(context.track, context.kart, 1, 2, context.lane_change_limit, context.seed))
        self._trackers = (ego, other)
        self.stats = RolloutStats()

    # ------------------------------------------------------------------ the check
    def _rival(self, observation: Observation) -> KartView | None:
        """The nearest kart ahead within ``reach`` or alongside (within 3 m behind)."""
        assert self._context is not None
        track = self._context.track
        me = observation.me
        best, best_gap = None, math.inf
        for k in observation.others():
            gap = (k.checkpoints_passed - me.checkpoints_passed) * 0.0 + track.gap(me.progress, k.progress)
            if -3.0 < gap < self.reach and abs(gap) < best_gap:
                best, best_gap = k, abs(gap)
        return best

    def _place(self, slot: int, view: KartView) -> None:
        assert self._world is not None and self._context is not None
        world, track = self._world, self._context.track
        _, tangent = track.point_at(view.progress)
        offset = math.remainder(view.heading - math.atan2(float(tangent[1]), float(tangent[0])), 2 * math.pi)
        world.place_kart(0, slot, s=view.progress, d=view.lateral, heading_offset=offset, speed=view.speed,
                         wear=view.wear)
        i = world.istate[0, slot]
        i[st.I_CP_PASSED] = view.checkpoints_passed
        i[st.I_LANE] = view.lane
        i[st.I_LANE_COUNT] = view.lane_changes
        i[st.I_LANE_NOW] = view.lane_now or view.lane
        i[st.I_STEP_LANE_COUNT] = view.lane_changes_now

    def _rollout(self, observation: Observation, rival: KartView, ego_wps: tuple[Waypoint, ...],
                 rival_wps: tuple[Waypoint, ...], target: int) -> float:
        assert self._world is not None and self._trackers is not None
        world = self._world
        world.clear_race(0)
        self._place(0, observation.me)
        self._place(1, rival)
        plan = Plan(0, ego_wps[0].checkpoint - 1 if ego_wps else 0, {0: ego_wps, 1: rival_wps}, 0, 0, 0.0)
        # the karts are mid-corner: start each tracker (rate-limited steering) and each kart's slip at the steer the
        # tracker asks for now, not straight ahead
        views = observe(world, 0)
        max_steer = self._context.kart.max_steer_angle if self._context else 0.45
        for slot, tracker in enumerate(self._trackers):
            saved = tracker.params
            tracker.params = replace(saved, steer_rate=0.0)
            steer = tracker.act(views[slot], plan).steer
            tracker.params = saved
            world.fstate[0, slot, st.F_STEER] = steer
            world.fstate[0, slot, st.F_SLIP] = math.atan(0.5 * math.tan(steer * max_steer))
        crossed = [-1, -1]
        self.stats.rollouts += 1
        for n in range(self.max_steps):
            views = observe(world, 0)
            actions = world._no_action.copy()
            for slot, tracker in enumerate(self._trackers):
                if not views[slot].me.finished:
                    a = tracker.act(views[slot], plan)
                    actions[0, slot] = (a.steer, a.throttle)
            world.step(actions)
            for slot in (0, 1):
                if crossed[slot] < 0 and (world.istate[0, slot, st.I_CP_PASSED] >= target
                                          or world.istate[0, slot, st.I_FINISHED]):
                    crossed[slot] = n
            if min(crossed) >= 0 or bool(world.done[0]):
                break
        crossed = [self.max_steps if c < 0 else c for c in crossed]
        i = world.istate[0]
        bad = int(i[:, st.I_CONTACTS].sum() + i[:, st.I_FAULTS].sum() + i[0, st.I_ILLEGAL])
        return 0.02 * (crossed[1] - crossed[0]) - PENALTY * bad

    def plan(self, observation: Observation) -> Plan:
        plan = self.inner.plan(observation)
        self.stats.plans += 1
        rival = self._rival(observation)
        ego_wps = plan.ego_waypoints
        if rival is None or len(ego_wps) < self.depth + 1:
            return plan
        self.stats.checked += 1
        assert self._context is not None
        track = self._context.track
        line_lanes = self.inner._line_lanes
        n = track.n_checkpoints
        rival_wps = tuple(w for w in plan.waypoints.get(rival.index, ()))
        head, window, tail = ego_wps[:1], ego_wps[1 : 1 + self.depth], ego_wps[1 + self.depth :]
        options = {tuple(w.lane for w in window)}
        options.add(tuple(line_lanes[w.checkpoint % n] for w in window))
        for lane in range(1, track.n_lanes + 1):
            options.add((lane,) * len(window))
        if self.exhaustive:
            options.update(itertools.product(range(1, track.n_lanes + 1), repeat=len(window)))
        target = window[-1].checkpoint + self.settle

        def waypoints(lanes: tuple[int, ...]) -> tuple[Waypoint, ...]:
            changed = []
            for w, lane in zip(window, lanes):
                point = track.lane_point(w.checkpoint % n, lane)
                changed.append(replace(w, lane=lane, position=(float(point[0]), float(point[1]))))
            return (*head, *changed, *tail)

        searched = tuple(w.lane for w in window)
        scores = {lanes: self._rollout(observation, rival, waypoints(lanes), rival_wps, target) for lanes in options}
        best = max(scores, key=lambda lanes: scores[lanes])
        if self.trace is not None:
            self.trace.append((round(observation.time, 2), window[0].checkpoint, searched,
                               {k: round(v, 2) for k, v in sorted(scores.items())}))
        if best == searched or scores[best] < scores[searched] + self.margin:
            return plan
        self.stats.replaced += 1
        new = waypoints(best)
        self.inner._committed = {w.checkpoint: w.lane for w in new}
        return replace(plan, waypoints={**plan.waypoints, plan.ego: new})


def verified_mcts_lqng(opponent_tracking: LQNGParams = FIXED_LINE_TRACKING, **kw: float) -> HierarchicalController:
    settings = MCTSLQNGParams()
    inner = MCTSPlanner.from_settings(settings, hold_gain=settings.hold_gain_s)
    ego_tracking = CLOSE_FOLLOWING_TRACKING
    planner = VerifiedPlanner(inner, ego_tracking, opponent_tracking, **kw)  # type: ignore[arg-type]
    return HierarchicalController("mcts-lqng-verified", planner, LQNGTracker(ego_tracking))
