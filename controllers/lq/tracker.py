"""The LQNG tracker (paper section 4.2.3, eqs. (20)-(24)): a linear-quadratic Nash game over a few 0.02 s
steps, re-solved at every simulation step, that tracks the next waypoint while denying the opponents theirs
and keeping apart.

This module picks each player's targets (aim point, speed) and the weights; :mod:`controllers.lq.game` turns
them into the game (dynamics linearised at the current state, eq. (24) lqng_dyn) and
:mod:`controllers.lq.nash` solves it. Costs of player i (1/2 x'Qx + q'x), assembled as eq. (23) lqng_obj:

* eq. (20) lqng_obj1, own waypoint: w_pos |p_i - psi_i|^2 + w_v (v_i - psi_v)^2 + w_theta (dtheta_i - psi_theta)^2;
* eq. (21) lqng_obj2, denial: - w_deny |p_j - psi_j|^2 for each opponent j with a predicted waypoint within reach;
* eq. (22) lqng_obj3, separation: - w_avoid |p_i - p_j|^2 for each kart within ``avoid_radius``;
* controls: 1/2 r |u_i|^2 (not in eq. (23)).

The heading target points at a pure-pursuit aim point on the path that blends the kart's lateral offset
into the next waypoints' lanes along the track (a heading straight at a lane point would cut the inside of
bends). The tracker's acceleration and yaw rate are mapped to throttle and steer.

Driving in traffic beyond the game's own costs is the job of named traffic rules (:mod:`controllers.lq.traffic`),
composed per agent in :mod:`controllers.lq.presets`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from controllers.base import Action, RaceContext
from controllers.lq.targets import AIM_OFFSET, HEADING_ERROR, SPEED_TARGET, TrackerTables, player_targets, solve_targets
from controllers.lq.traffic import ExactLanes, LateralBound, SpeedLimit, SteerFilter, TrafficRule, TrafficScene
from controllers.plan import Plan, Waypoint
from controllers.racing_line import RacingLine, optimise_racing_line
from sim_core.kart import throttle_for_acceleration
from sim_core.observation import KartView, Observation
from sim_core.params import DT
from sim_core.track import Track


def _player_row(kart: KartView) -> tuple[float, ...]:
    """A player's row of :func:`controllers.lq.targets.player_targets` (``PX`` ... ``PLATERAL``)."""
    return (kart.x, kart.y, kart.heading, kart.speed, kart.progress, kart.lateral)


def _waypoint_rows(first: Waypoint, second: Waypoint) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """A player's two waypoint rows (``WCHECKPOINT`` ... ``WSPEED``)."""
    return tuple((w.checkpoint, w.lane, w.position[0], w.position[1], w.speed) for w in (first, second))  # type: ignore[return-value]


def within(first: tuple[float, float] | None, second: tuple[float, float] | None) -> tuple[float, float] | None:
    """The lateral bounds both ``first`` and ``second`` allow; ``first``'s alone where the two do not overlap (a
    preset lists its bounding rules in priority order: holding a lane boundary beats closing a little on a kart
    alongside)."""
    if first is None or second is None:
        return first or second
    lowest, highest = max(first[0], second[0]), min(first[1], second[1])
    return (lowest, highest) if lowest <= highest else first


@dataclass(frozen=True)
class LQNGWeights:
    """Weights of the tracker's game (defaults follow the original's magnitudes, spec section 5)."""

    position: float = 0.93  # w_pos = position / max(1, v)
    speed: float = 1.0  # w_v: pulls the speed to the planned speed
    heading: float = 3.5  # w_theta (the original: 3.5 with MCTS, 1.9 with the fixed line)
    # w_deny = deny / max(1, v) on the opponent's predicted waypoint; the original's 0.2 made the kart push the other
    deny: float = 0.02
    avoid_scale: float = 1.0  # w_avoid = 1 / (d^1.5 * avoid_scale) (the original: 1.0 MCTS, 0.45 fixed)
    opponent_avoid_scale: float = 1.3  # the same for the opponents' assumed costs
    control: float = 0.115  # r
    avoid_radius: float = 8.0  # [m] players closer than this enter the game


@dataclass(frozen=True)
class LQNGParams:
    """Tracker settings (its traffic rules are separate parts: :mod:`controllers.lq.traffic`)."""

    horizon: int = 4  # steps of 0.02 s (the paper: 0.06-0.08 s)
    lookahead_time: float = 0.45  # [s] pure-pursuit lookahead = max(min_lookahead, v * this)
    min_lookahead: float = 3.0  # [m]
    speed_margin: float = 1.0  # [m/s] added to planned speeds (the original added 2 bin widths)
    braking_use: float = 0.8  # fraction of the braking limit the speed target assumes
    lane_tolerance: float = 1.25  # [m] a waypoint lane within this of the racing line needs no correction
    # [m] the same with another kart within avoid_radius: planned lanes are then driven as planned, or two karts
    # planned into neighbouring lanes would both close onto the line and touch
    traffic_lane_tolerance: float = 0.0
    # [1/s] over a traffic rule's speed limit the kart brakes at this deceleration per m/s over at once (the LQ
    # speed weight is too soft for it)
    limit_brake_gain: float = 3.0
    # fraction of its speed targets the kart drives at (its top speed included): 1 is all out, under 1 a
    # handicapped, uniformly slower kart (an opponent to test passing against)
    speed_scale: float = 1.0
    weights: LQNGWeights = LQNGWeights()


class LQNGTracker:
    """Linear-quadratic Nash game tracker; works with any plan (MCTS waypoints or the fixed racing line), with
    ``rules`` (:mod:`controllers.lq.traffic`) for traffic."""

    def __init__(self, params: LQNGParams | None = None, rules: Sequence[TrafficRule] = ()) -> None:
        self.params = params or LQNGParams()
        self.rules = tuple(rules)
        self._exact = [r for r in self.rules if isinstance(r, ExactLanes)]
        self._bounds = [r for r in self.rules if isinstance(r, LateralBound)]
        self._limits = [r for r in self.rules if isinstance(r, SpeedLimit)]
        self._steer_filters = [r for r in self.rules if isinstance(r, SteerFilter)]
        self._context: RaceContext | None = None
        self._line: RacingLine | None = None
        self._kart_vector = np.zeros(0)
        self._steer = 0.0
        self._tables: TrackerTables | None = None

    def reset(self, context: RaceContext) -> None:
        """Remember the track and kart limits and get the track's racing line (the shape followed between
        waypoints that agree with it)."""
        self._context = context
        self._kart_vector = context.kart.as_array()
        self._steer = 0.0
        self._line = optimise_racing_line(context.track, context.kart)
        self._tables = TrackerTables.of(context.track, self._line)

    # ------------------------------------------------------------------ targets
    def _upcoming(self, track: Track, kart: KartView, plan: Plan | None, owner: int) -> tuple[Waypoint, Waypoint]:
        """The next two waypoints of ``owner`` still ahead of ``kart`` (its current lane when none is planned)."""
        ahead: list[Waypoint] = []
        if plan is not None:
            ahead = [w for w in plan.waypoints.get(owner, ()) if w.checkpoint > kart.checkpoints_passed]
        while len(ahead) < 2:
            checkpoint = kart.checkpoints_passed + 1 + len(ahead)
            lane = ahead[-1].lane if ahead else kart.lane
            point = track.lane_point(checkpoint, lane)
            ahead.append(Waypoint(checkpoint, lane, (float(point[0]), float(point[1])), 15.0, 0.0))
        return ahead[0], ahead[1]

    def _targets(
        self, state: np.ndarray, waypoints: np.ndarray, tolerance: float, bounds: tuple[float, float] | None
    ) -> np.ndarray:
        """Per player (rows of ``state``, the ego first; ``waypoints`` its next two): its aim point's lateral
        offset, its heading error to the aim and its speed target (:func:`controllers.lq.targets.player_targets`:
        a pure-pursuit aim on the path blending the kart's lateral offset into the waypoints' lanes, the ego's held
        within ``bounds`` (lowest, highest offset) if given)."""
        assert self._context is not None and self._tables is not None, "reset() first"
        p, kart, tables = self.params, self._context.kart, self._tables
        return player_targets(
            state,
            waypoints,
            tolerance,
            np.array(bounds or (-math.inf, math.inf)),
            p.min_lookahead,
            p.lookahead_time,
            kart.top_speed,
            kart.braking,
            p.braking_use,
            p.speed_margin,
            tables.length,
            tables.checkpoint_s,
            tables.lane_offsets,
            tables.segment_starts,
            tables.segment_ends,
            tables.segment_deltas,
            tables.segment_tangents,
            tables.centre_xy,
            tables.line_length,
            tables.line_s,
            tables.line_offset,
            tables.line_offset_slope,
            tables.line_speed,
            tables.line_speed_slope,
        )

    def aim_offset(
        self,
        kart: KartView,
        first: Waypoint,
        second: Waypoint,
        tolerance: float,
        bounds: tuple[float, float] | None = None,
    ) -> float:
        """[m] the lateral offset ``kart`` steers for, driving for ``first`` and ``second`` with lanes within
        ``tolerance`` of the racing line not corrected, held within ``bounds`` if given."""
        state = np.array([_player_row(kart)])
        return float(self._targets(state, np.array([_waypoint_rows(first, second)]), tolerance, bounds)[0, AIM_OFFSET])

    # ------------------------------------------------------------------ control
    def scene(self, observation: Observation, plan: Plan | None) -> TrafficScene:
        """What the traffic rules see now: the karts within the game's reach, the plan, the ego's next waypoints."""
        assert self._context is not None and self._line is not None, "reset() first"
        me = observation.me
        radius = self.params.weights.avoid_radius
        others = [k for k in observation.others() if math.hypot(k.x - me.x, k.y - me.y) < radius]
        track = self._context.track
        return TrafficScene(
            track,
            me,
            others,
            plan,
            self._line,
            self._upcoming(track, me, plan, me.index),
            self._context.lane_change_limit,
            self.params.speed_scale,
            self.params.lookahead_time,
            self.params.min_lookahead,
        )

    def act(self, observation: Observation, plan: Plan | None) -> Action:
        """Solve the game at the current state and map the ego's first control to steer and throttle, then the
        steer filters."""
        action = self._solved_action(observation, plan)
        steer = action.steer
        for rule in self._steer_filters:
            steer = rule.filter_steer(steer, self._steer)
        self._steer = steer
        return Action(steer, action.throttle)

    def _solved_action(self, observation: Observation, plan: Plan | None) -> Action:
        """The game's first control as steer and throttle, with the traffic rules' lanes, bounds and speed limits
        (the aims, speed targets and the game in compiled code: :mod:`controllers.lq.targets`)."""
        assert self._context is not None, "reset() first"
        ctx, p = self._context, self.params
        track, kart = ctx.track, ctx.kart
        scene = self.scene(observation, plan)
        me, others = scene.me, scene.others
        players = [me, *others]
        tolerance = p.traffic_lane_tolerance if others else p.lane_tolerance
        if any(rule.exact_lanes(scene) for rule in self._exact):
            tolerance = 0.0
        rows, waypoints = [], []
        for i, k in enumerate(players):
            rows.append(_player_row(k))
            first, second = scene.upcoming if i == 0 else self._upcoming(track, k, plan, k.index)
            waypoints.append(_waypoint_rows(first, second))
        state = np.array(rows)
        aims = self._targets(state, np.array(waypoints), tolerance, self._lateral_bounds(scene))
        station = math.inf
        for rule in self._limits:
            station = min(station, rule.speed_limit(scene, float(aims[0, AIM_OFFSET])))
        targets = np.empty((len(players), 4))
        for i, (_, _, first_x, first_y, _) in enumerate(w[0] for w in waypoints):
            speed = float(aims[i, SPEED_TARGET])
            if i == 0:
                speed = min(speed * p.speed_scale, station)
            # the game's position target is the first waypoint (relative to the ego), its heading target the aim
            targets[i] = (first_x - me.x, first_y - me.y, speed, aims[i, HEADING_ERROR])
        P, alpha, x0 = self._solve(state, targets, players, plan)
        accel, yaw_rate = -(P[0][0:2] @ x0) - alpha[0][0:2]
        if me.speed > station:
            # over a traffic rule's limit: brake at once (the LQ speed weight is too soft for it)
            accel = min(float(accel), -p.limit_brake_gain * (me.speed - station))
        throttle = throttle_for_acceleration(self._kart_vector, me.speed, float(accel))
        speed = max(abs(me.speed), 1.0)
        steer = min(max(math.atan(yaw_rate * kart.wheelbase / speed) / kart.max_steer_angle, -1.0), 1.0)
        return Action(steer, min(max(float(throttle), -1.0), 1.0))

    def _lateral_bounds(self, scene: TrafficScene) -> tuple[float, float] | None:
        """The bounding rules' lateral bounds, intersected in the preset's order (:func:`within`)."""
        bounds: tuple[float, float] | None = None
        for rule in self._bounds:
            bounds = within(bounds, rule.bounds(scene))
        return bounds

    @property
    def last_steer(self) -> float:
        """The steer last sent, from which the steer filters limit the next (the tracker's only memory)."""
        return self._steer

    @last_steer.setter
    def last_steer(self, steer: float) -> None:
        self._steer = steer

    def _solve(
        self, state: np.ndarray, targets: np.ndarray, players: list[KartView], plan: Plan | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The game's feedback Nash gains (``P``, ``alpha``) and its state ``x0``, eq. (23) lqng_obj for every
        player: its waypoint (20) paid, the separation from each other player (22) earned, and for the ego alone
        the denial (21) of each opponent's predicted waypoint. The opponents are assumed to play the same game
        with their own avoidance scale and no denial."""
        w = self.params.weights
        denied = np.array([i > 0 and plan is not None and k.index in plan.waypoints for i, k in enumerate(players)])
        return solve_targets(
            state,
            targets,
            denied,
            w.position,
            w.speed,
            w.heading,
            w.avoid_scale,
            w.opponent_avoid_scale,
            w.deny,
            w.control,
            DT,
            self.params.horizon,
        )
