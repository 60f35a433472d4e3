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

import math
from dataclasses import dataclass, replace

from controllers.base import RaceContext
from controllers.parameters import InvalidValueError, parameter
from controllers.plan import Plan, Waypoint
from controllers.racing_line import RacingLine, optimise_racing_line
from controllers.tactical.game import GameParams
from controllers.tactical.opponents import ADAPTIVE_MODELS, AgentFactory, OpponentModelSelector, model_names
from controllers.tactical.opponents import RacingLine as RacingLineModel
from controllers.tactical.pace import PaceMeter
from controllers.tactical.planner import PlayerState, TacticalPlanner
from sim_core.observation import KartView, Observation
from sim_core.rules import lane_change_update
from sim_core.track import Track

INTERACTION_WINDOW = 1.0  # [s] another kart predicted at a checkpoint this much earlier makes it tactical
# [s] ... or this much later: a kart behind by more than about a kart length cannot be blocked without losing
# time (it must keep its distance, the follower's duty), so a leader defends by driving the racing line
BEHIND_WINDOW = 0.15
DEVIATION_GAIN = 0.1  # [s] default of MCTSPlanner.deviation_gain
HOLD_GAIN = 0.05  # [s] mcts-lqng's default of MCTSPlanner.hold_gain
MAX_SQUEEZE_LOOKAHEAD = 2.0  # [s] how far ahead a kart alongside is extrapolated sideways (MCTSPlanner._no_squeeze)


@dataclass(frozen=True)
class TacticalParams:
    """The public parameters every MCTS-planned agent shares (a registered agent's parameter dataclass extends
    it): the search's budget and rate, the game's horizon, when the searched lanes replace the racing line, and
    the pace the ego assumes for itself until measured."""

    # at the maximum a plan takes ~0.4 s (2 karts) and the reused search tree, 8 plans' budgets, ~75 MB
    iterations: int = parameter(2000, "MCTS iterations per plan", minimum=1, maximum=20_000)
    horizon: int = parameter(8, "checkpoints the tactical game looks ahead", minimum=1, maximum=16)
    planner_rate_hz: float = parameter(1.0, "re-plans per second", unit="Hz", minimum=0.1, maximum=10.0)
    deviation_gain_s: float = parameter(
        DEVIATION_GAIN,
        "time the searched lanes must gain on the others over the racing line's to replace it, both played out "
        "the same deterministic way (ours, not the paper's: the search's principal line is too noisy to read as a "
        "forecast)",
        unit="s",
        minimum=0.0,
        maximum=5.0,
    )
    own_pace: float = parameter(
        1.0,
        "the ego's pace (its section times over the racing line's) until it has been measured in clean air; the "
        "game times every kart by its pace measured this race",
        minimum=0.8,
        maximum=1.3,
    )


@dataclass(frozen=True)
class AdaptiveOpponentParams(TacticalParams):
    """:class:`TacticalParams` with the opponent models the game chooses from per kart by measured error."""

    opponent_models: str = parameter(
        ADAPTIVE_MODELS,
        "opponent models the tactical game plays each other kart by, the one with the fewest missed lane forecasts "
        "for that kart so far, joined by '+' (racing-line, holds-lane, game, own-last-lap, simulated-AGENT; the "
        "first until measured)",
    )

    def __post_init__(self) -> None:
        try:
            model_names(self.opponent_models)
        except ValueError as exc:
            raise InvalidValueError("opponent_models", str(exc)) from None


def lanes_legal(track: Track, lane: int, count: int, waypoints: list[Waypoint], limit: int) -> bool:
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
    up to the gap between a tactical planner and a line follower.
    """

    def __init__(
        self,
        iterations: int = 2000,
        rate_hz: float = 1.0,
        params: GameParams | None = None,
        racing_line: bool = True,
        lane_change_slack: int = 0,
        deviation_gain: float | None = DEVIATION_GAIN,
        hold_gain: float | None = None,
        planned_speeds_behind: bool = True,
        pace_model: bool = False,
        own_pace: float = 1.0,
        opponent_models: tuple[str, ...] = (RacingLineModel.name,),
        agent_factory: AgentFactory | None = None,
    ) -> None:
        if lane_change_slack < 0:
            raise ValueError("lane_change_slack must be >= 0")
        if deviation_gain is not None and deviation_gain < 0:
            raise ValueError("deviation_gain must be >= 0 (or None)")
        if hold_gain is not None and (hold_gain < 0 or deviation_gain is None):
            raise ValueError("hold_gain must be >= 0 (or None) and needs deviation_gain")
        self.iterations = iterations
        self.rate_hz = rate_hz
        self.params = params or GameParams()
        self.racing_line = racing_line
        # lanes of the rule's limit L left unplanned on each straight: a tracker that does not hit its lanes
        # exactly (a learned one) may cross a boundary once more than the plan, which the referee counts
        self.lane_change_slack = lane_change_slack
        # [s] with the racing line on, the searched lanes replace the line's only when the game's playout of
        # them gains this much (:meth:`TacticalPlanner._line_unless_beaten`); None: the search's lanes always
        self.deviation_gain = deviation_gain
        # [s] the previous plan's lanes, where they leave the line, are kept while they still gain this much on it
        # (:meth:`TacticalPlanner._line_unless_beaten`); None: every plan chosen afresh
        self.hold_gain = hold_gain
        # behind another kart a waypoint keeps the game's planned speed: the spacing of a tracker that keeps none
        # of its own (LQNG); off, the line's speed profile binds everywhere and the tracker keeps its distance
        # (the RL trackers' following shield)
        self.planned_speeds_behind = planned_speeds_behind
        # every kart's section times scaled by its pace measured in clean air (controllers.tactical.pace); the
        # ego's is ``own_pace`` until it has one, another kart's the ego's until it has one
        self.pace_model = pace_model
        self.own_pace = own_pace
        # how the game plays each other kart: the model of these with the fewest missed lanes for that kart so far
        # (controllers.tactical.opponents; the first until measured)
        self.opponents = OpponentModelSelector.of(opponent_models, agent_factory)
        self._pace: PaceMeter | None = None
        self._planner: TacticalPlanner | None = None
        self._context: RaceContext | None = None
        self._line_lanes: tuple[int, ...] = ()
        self._line: RacingLine | None = None
        self._committed: dict[int, int] = {}

    @classmethod
    def from_settings(
        cls,
        settings: TacticalParams,
        *,
        lane_change_slack: int = 0,
        planned_speeds_behind: bool = True,
        hold_gain: float | None = None,
        agent_factory: AgentFactory | None = None,
    ) -> MCTSPlanner:
        """The planner of a registered agent's ``settings``: the racing line unless the search gains, every kart
        timed by its measured pace and played by the opponent models of ``settings`` (the racing line's
        without)."""
        opponent_models: tuple[str, ...] = (RacingLineModel.name,)
        if isinstance(settings, AdaptiveOpponentParams):
            opponent_models = model_names(settings.opponent_models)
        return cls(
            iterations=settings.iterations,
            rate_hz=settings.planner_rate_hz,
            params=GameParams(horizon=settings.horizon),
            lane_change_slack=lane_change_slack,
            deviation_gain=settings.deviation_gain_s,
            hold_gain=hold_gain,
            planned_speeds_behind=planned_speeds_behind,
            pace_model=True,
            own_pace=settings.own_pace,
            opponent_models=opponent_models,
            agent_factory=agent_factory,
        )

    @property
    def line_lanes(self) -> tuple[int, ...]:
        """The offline racing line's lane at each checkpoint (set by :meth:`reset`)."""
        return self._line_lanes

    def commit(self, plan: Plan) -> None:
        """Hold ``plan``'s ego lanes as the commitment of the next search (a plan changed after the search by a
        wrapping planner is the one the kart drives)."""
        self._committed = {w.checkpoint: w.lane for w in plan.ego_waypoints}

    @property
    def lane_limit(self) -> int:
        """The lane-change limit the plans keep to: the race's L less the slack (never below 0)."""
        assert self._context is not None, "reset() first"
        return max(self._context.lane_change_limit - self.lane_change_slack, 0)

    def reset(self, context: RaceContext) -> None:
        """Build the game tables for this track and kart (and the racing line's lanes)."""
        self._context = context
        self._line = optimise_racing_line(context.track, context.kart)
        self._line_lanes = self._line.checkpoint_lanes
        self._committed = {}
        self.opponents.reset(context.track, self._line_lanes)
        self._pace = PaceMeter.of(context.track, self._line) if self.pace_model else None
        self._planner = TacticalPlanner(
            context.track,
            context.kart,
            self.params,
            iterations=self.iterations,
            seed=context.seed,
            lane_limit=self.lane_limit,
            line=self._line,
            deviation_gain=self.deviation_gain if self.racing_line else None,
            hold_gain=self.hold_gain if self.racing_line else None,
        )

    def present_state(self, kart: KartView, now: float, ego: int) -> PlayerState:
        """A kart's predicted crossing of its next checkpoint, from its present progress and speed (a standing
        start included): the time from constant acceleration (or braking) toward the racing line's speed there;
        the lane: the ego's committed lane there, else the lane nearest its present lateral offset."""
        assert self._context is not None and self._line is not None and self._planner is not None
        track = self._context.track
        tb = self._planner.tables
        checkpoint = max(kart.checkpoints_passed, 0) + 1
        s_next = float(track.checkpoint_s[checkpoint % track.n_checkpoints])
        distance = max((s_next - kart.progress) % track.length, 0.05)
        v0 = max(kart.speed, 0.0)
        v_line = float(self._line.speed_at(s_next))
        if v0 <= v_line:
            v1 = min(v_line, math.sqrt(v0 * v0 + 2.0 * tb.accel * distance))
        else:
            v1 = max(v_line, math.sqrt(max(v0 * v0 - 2.0 * tb.brake * distance, 0.0)))
        lane = track.lane_id(checkpoint, kart.lateral)
        if kart.index == ego:
            lane = self._committed.get(checkpoint, lane)
        straight = (track.section_is_straight(checkpoint - 1), track.section_is_straight(checkpoint))
        limit = self._context.lane_change_limit
        count, _ = lane_change_update(kart.lane_changes, kart.lane, lane, *straight, limit)
        if kart.lane_now > 0:
            # the referee counts lane changes as they happen (the default rule) or at checkpoint crossings; the
            # two differ by a change made just past a change of road type, which the sampled count absorbs into
            # its reset: plan with the stricter, or a plan to the limit breaks it by one
            as_they_happen, _ = lane_change_update(kart.lane_changes_now, kart.lane_now, lane, *straight, limit)
            count = max(count, as_they_happen)
        return PlayerState(
            kart=kart.index,
            checkpoint=checkpoint,
            lane=lane,
            speed=v1,
            time=now + 2.0 * distance / max(v0 + v1, 0.5),
            wear=kart.wear,
            lane_changes=count,
            pace=self.pace_of(kart.index, ego),
            team=self._context.teams[kart.index] if self._context.teams else 0,
        )

    def _with_model(self, player: PlayerState, kart: KartView, ego: int) -> PlayerState:
        """``player`` played by the opponent model chosen for its kart (the ego searches)."""
        if kart.index == ego:
            return player
        model = self.opponents.model_of(kart.index).in_game(kart)
        return replace(player, model=model.code, script=model.lanes)

    def pace_of(self, kart: int, ego: int) -> float:
        """The pace the game gives ``kart`` (1 without the pace model): its measured one, else the ego's."""
        if self._pace is None:
            return 1.0
        mine = self._pace.pace(ego, self.own_pace)
        return mine if kart == ego else self._pace.pace(kart, mine)

    def _no_squeeze(self, plan: Plan, me: PlayerState, karts: tuple[KartView, ...]) -> Plan:
        """``plan`` with the ego's first waypoint after its next checkpoint kept in the ego's lane there when it
        would steer toward a kart now alongside (ahead by less than the game's collision distance, or behind with
        its body still overlapping the ego's) and
        end closer than the game's lateral clearance to where that kart will be (at its present sideways speed),
        or beyond it, where the lane-change rule allows. The game starts from the next crossings and times the
        karts' moves apart by their speed bins, so it can send the ego across a kart it is level with (both at
        fault)."""
        assert self._context is not None
        track = self._context.track
        here = next(k for k in karts if k.index == me.kart)
        waypoints = list(plan.ego_waypoints)
        if not waypoints or waypoints[0].checkpoint != me.checkpoint + 1 or waypoints[0].lane == me.lane:
            return plan
        first = waypoints[0]
        toward = first.lane - me.lane  # > 0: toward the right (lane ids grow to the right)
        s_first = float(track.checkpoint_s[first.checkpoint % track.n_checkpoints])
        reach_time = min(((s_first - here.progress) % track.length) / max(here.speed, 1.0), MAX_SQUEEZE_LOOKAHEAD)
        target = float(track.lane_offsets(first.checkpoint)[first.lane - 1])
        kart = self._context.kart
        body_length = kart.body_length
        for other in karts:
            if other.index == me.kart or other.finished:
                continue
            gap = track.gap(here.progress, other.progress)
            side = other.lateral - here.lateral  # > 0: it is on my left
            # ahead: anything within the collision distance is ours to avoid; behind: only a kart still
            # overlapping us, since a follower clear of our tail must keep its distance (and crossing in front
            # of it is how a leader takes the line: holding our lane there lost 9 of 25 lane-2 starts on
            # complex-reversed)
            if not (-body_length < gap < self.params.collision_distance) or toward * side >= 0:
                continue
            # where it will be by then, at its present sideways speed
            _, tangent = track.point_at(other.progress)
            drift = other.speed * math.sin(other.heading - math.atan2(float(tangent[1]), float(tangent[0])))
            # it stays on its side of my new lane by the clearance, or we squeeze (or cross) each other
            if (
                math.copysign(1.0, side) * (other.lateral + drift * reach_time - target)
                >= self.params.lateral_clearance
            ):
                continue
            point = track.lane_point(first.checkpoint, me.lane)
            kept = replace(first, lane=me.lane, position=(float(point[0]), float(point[1])))
            if lanes_legal(track, me.lane, me.lane_changes, [kept, *waypoints[1:]], self.lane_limit):
                return replace(plan, waypoints={**plan.waypoints, plan.ego: (kept, *waypoints[1:])})
        return plan

    def plan(self, observation: Observation) -> Plan:
        """Search from every kart's predicted crossing of its next checkpoint (:meth:`present_state`); the ego
        does not steer into a kart alongside it (:meth:`_no_squeeze`)."""
        assert self._planner is not None and self._context is not None, "reset() first"
        if self._pace is not None:
            self._pace.observe(observation.karts, self._context.track)
        ego = observation.ego
        others = [k for k in observation.karts if k.index != ego]
        self.opponents.score(others)
        players = [
            self._with_model(self.present_state(k, observation.time, ego), k, ego)
            for k in observation.karts
            if not k.finished or k.index == ego
        ]
        if len(self.opponents.models) > 1:
            planner = self._planner
            self.opponents.forecast(others, lambda kart: planner.best_response_lanes(players, ego, kart))
        plan = self._planner.plan(players, ego, self._committed)
        me = next(p for p in players if p.kart == observation.ego)
        plan = self._fill_skipped(plan, me)
        if self.racing_line:
            plan = self._prefer_racing_line(plan, me.lane, me.lane_changes, self._clear_behind(observation))
        plan = self._no_squeeze(plan, me, observation.karts)
        # the root's own crossing (the lane the kart is committed to at its next checkpoint) leads the plan, at the
        # speed predicted there (the line's, as far as reachable) even without planned speeds behind: mcts-rl's
        # policy brakes for it into hairpins. At top speed there it was faster alone on oval and lost in traffic on
        # complex (the paper grid: 329 of 400 wins against 364)
        point = self._context.track.lane_point(me.checkpoint, me.lane) if self._context else (0.0, 0.0)
        first = Waypoint(me.checkpoint, me.lane, (float(point[0]), float(point[1])), me.speed, 0.0)
        plan = replace(plan, waypoints={**plan.waypoints, plan.ego: (first, *plan.ego_waypoints)})
        self.commit(plan)
        return plan

    def _fill_skipped(self, plan: Plan, me: PlayerState) -> Plan:
        """``plan`` with ego waypoints at the checkpoints between the ego's next one and the game's root, which
        the search never plays: a kart behind the leader's checkpoint enters the game advanced to it in its own
        lane (:meth:`~controllers.tactical.planner.TacticalPlanner.root_state`). Without them the tracker would
        skip a checkpoint's lane, and the next plan would take whatever lane the kart then happens to be in.
        They hold the ego's lane here; :meth:`_prefer_racing_line` then moves them to the line where legal."""
        assert self._context is not None
        track = self._context.track
        skipped = range(me.checkpoint + 1, plan.root_checkpoint + 1)
        if not skipped:
            return plan
        filled = []
        for c in skipped:
            point = track.lane_point(c, me.lane)
            filled.append(Waypoint(c, me.lane, (float(point[0]), float(point[1])), me.speed, 0.0))
        return replace(plan, waypoints={**plan.waypoints, plan.ego: (*filled, *plan.ego_waypoints)})

    def _clear_behind(self, observation: Observation) -> frozenset[int]:
        """The karts now behind the ego by more than half a body length (their nose behind its middle), or a lap
        down: followers whose duty it is to keep their distance (eqs. (8)-(9) gen_coll_avoid), so the ego leads
        them on the racing line whatever the game predicts."""
        assert self._context is not None
        track = self._context.track
        body_length = self._context.kart.body_length
        me = next(k for k in observation.karts if k.index == observation.ego)
        clear = set()
        for other in observation.karts:
            if other.index == observation.ego or other.finished:
                continue
            checkpoints_ahead = me.checkpoints_passed - other.checkpoints_passed
            gap = track.gap(me.progress, other.progress)
            if checkpoints_ahead >= track.n_checkpoints or (gap < -0.5 * body_length and checkpoints_ahead >= 0):
                clear.add(other.index)
        return frozenset(clear)

    def _prefer_racing_line(
        self, plan: Plan, lane: int, count: int, clear_behind: frozenset[int] = frozenset()
    ) -> Plan:
        """``plan`` with every non-tactical ego waypoint moved to the racing line's lane where that is legal,
        and every waypoint with no kart ahead (or every waypoint, with ``planned_speeds_behind`` off) at top speed
        (the tracker then drives the line's speed profile).

        A waypoint is tactical when another kart is predicted at its checkpoint up to ``INTERACTION_WINDOW``
        before the ego, or up to ``BEHIND_WINDOW`` after it unless that kart is ``clear_behind`` now: the game's
        predicted gap to a follower is coarse (its speed bins), and a leader that reads a follower a body
        length back as level defends with lanes that cost more than the follower could gain (on
        complex-reversed the follower then went round the outside of the first hairpin)."""
        assert self._context is not None
        track = self._context.track
        limit = self.lane_limit
        opponents = [
            (w, BEHIND_WINDOW if k not in clear_behind else 0.0)
            for k, ws in plan.opponent_waypoints().items()
            for w in ws
        ]
        waypoints = list(plan.ego_waypoints)
        for i, w in enumerate(waypoints):
            line_lane = self._line_lanes[w.checkpoint % track.n_checkpoints]
            tactical = any(
                o.checkpoint == w.checkpoint and -INTERACTION_WINDOW < o.time - w.time < after for o, after in opponents
            )
            behind = any(
                o.checkpoint == w.checkpoint and -INTERACTION_WINDOW < o.time - w.time <= 0.0 for o, _ in opponents
            )
            if not behind or not self.planned_speeds_behind:
                # nobody ahead to keep a distance from: the racing line's speed profile (the tracker's) binds,
                # not the game's coarse speed bins
                waypoints[i] = w = replace(w, speed=self._context.kart.top_speed)
            if line_lane != w.lane and not tactical:
                point = track.lane_point(w.checkpoint, line_lane)
                snapped = replace(w, lane=line_lane, position=(float(point[0]), float(point[1])))
                if lanes_legal(track, lane, count, [snapped, *waypoints[i + 1 :]], limit):
                    waypoints[i] = snapped
            c = waypoints[i].checkpoint
            count, _ = lane_change_update(
                count, lane, waypoints[i].lane, track.section_is_straight(c - 1), track.section_is_straight(c), limit
            )
            lane = waypoints[i].lane
        return replace(plan, waypoints={**plan.waypoints, plan.ego: tuple(waypoints)})
