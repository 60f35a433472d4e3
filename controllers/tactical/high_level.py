"""The tactical planner as a hierarchical driver's high-level part (``mcts-lqng``): MCTS over the discrete
game (:class:`~controllers.tactical.planner.TacticalPlanner`) from the karts' last checkpoint crossings,
with the offline racing line's lanes kept wherever no other kart interacts.

Two planners fill the high-level slot of :class:`~controllers.hierarchical.HierarchicalController`, named as
the paper names its variants (MCTS-* and Fixed-*, registered as ``mcts-*`` and ``fixed-*``): this one
*searches* the racing game against the other karts and predicts their best responses;
:class:`~controllers.fixed_line.FixedLinePlanner` *replays* the offline racing line and predicts nobody.
:class:`~controllers.tactical.planner.TacticalPlanner` is the search itself (game states in, plan out);
:class:`MCTSPlanner` adapts it to the :class:`~controllers.base.HighLevelPlanner` slot (observations in).
"""

from __future__ import annotations

from dataclasses import replace

from controllers.base import RaceContext
from controllers.plan import Plan, Waypoint
from controllers.racing_line import optimise_racing_line
from controllers.tactical.game import GameParams
from controllers.tactical.planner import PlayerState, TacticalPlanner
from sim_core.observation import Observation
from sim_core.rules import lane_change_update
from sim_core.track import Track

INTERACTION_WINDOW = 1.0  # [s] another kart predicted at a checkpoint this close in time makes it tactical


def _lanes_legal(track: Track, lane: int, count: int, waypoints: list[Waypoint], limit: int) -> bool:
    """Whether driving through ``waypoints`` from ``lane`` (lane-change counter ``count``) breaks no rule
    (eqs. (10) gen_lane_var and (11) gen_lane_lim, the referee's :func:`~sim_core.rules.lane_change_update`)."""
    for w in waypoints:
        c = w.checkpoint
        count, illegal = lane_change_update(
            count, lane, w.lane, track.section_is_straight(c - 1), track.section_is_straight(c), limit
        )
        if illegal:
            return False
        lane = w.lane
    return True


class MCTSPlanner:
    """The paper's tactical planner as a high-level part: MCTS over the discrete game.

    With ``racing_line`` on, the search decides the lanes only where karts interact: an ego waypoint with no
    other kart predicted at that checkpoint within ``INTERACTION_WINDOW`` takes the offline racing line's lane
    when the lane-change rule allows it. The discrete game's lane-radius time model cannot tell apart lane
    choices worth a few hundredths of a second each, and 2,000 iterations cannot either; over a lap they add
    up to the gap between a tactical planner and a line follower (measured in the closing note of issue 4).
    """

    def __init__(
        self, iterations: int = 2000, rate_hz: float = 1.0, params: GameParams | None = None, racing_line: bool = True
    ) -> None:
        self.iterations = iterations
        self.rate_hz = rate_hz
        self.params = params or GameParams()
        self.racing_line = racing_line
        self._planner: TacticalPlanner | None = None
        self._context: RaceContext | None = None
        self._line_lanes: tuple[int, ...] = ()

    def reset(self, context: RaceContext) -> None:
        """Build the game tables for this track and kart (and the racing line's lanes)."""
        self._context = context
        if self.racing_line:
            self._line_lanes = optimise_racing_line(context.track, context.kart).checkpoint_lanes
        self._planner = TacticalPlanner(
            context.track,
            context.kart,
            self.params,
            iterations=self.iterations,
            seed=context.seed,
            lane_limit=context.lane_change_limit,
        )

    def plan(self, observation: Observation) -> Plan:
        """Search from the karts' states at their last checkpoint crossings."""
        assert self._planner is not None, "reset() first"
        players = [
            PlayerState(
                kart=k.index,
                checkpoint=max(k.checkpoints_passed, 0),
                lane=k.lane,
                speed=k.crossing_speed,
                time=k.crossing_time,
                wear=k.crossing_wear,
                lane_changes=k.lane_changes,
            )
            for k in observation.karts
            if not k.finished or k.index == observation.ego
        ]
        plan = self._planner.plan(players, observation.ego)
        return self._prefer_racing_line(plan, observation) if self.racing_line else plan

    def _prefer_racing_line(self, plan: Plan, observation: Observation) -> Plan:
        """``plan`` with every non-tactical ego waypoint moved to the racing line's lane where that is legal."""
        assert self._context is not None
        track = self._context.track
        limit = self._context.lane_change_limit
        opponents = [w for ws in plan.opponent_waypoints().values() for w in ws]
        me = observation.me
        waypoints = list(plan.ego_waypoints)
        lane, count = me.lane, me.lane_changes
        for i, w in enumerate(waypoints):
            line_lane = self._line_lanes[w.checkpoint % track.n_checkpoints]
            tactical = any(
                o.checkpoint == w.checkpoint and abs(o.time - w.time) < INTERACTION_WINDOW for o in opponents
            )
            if line_lane != w.lane and not tactical:
                point = track.lane_point(w.checkpoint, line_lane)
                snapped = replace(w, lane=line_lane, position=(float(point[0]), float(point[1])))
                if _lanes_legal(track, lane, count, [snapped, *waypoints[i + 1 :]], limit):
                    waypoints[i] = snapped
            c = waypoints[i].checkpoint
            count, _ = lane_change_update(
                count, lane, waypoints[i].lane, track.section_is_straight(c - 1), track.section_is_straight(c), limit
            )
            lane = waypoints[i].lane
        return replace(plan, waypoints={**plan.waypoints, plan.ego: tuple(waypoints)})
