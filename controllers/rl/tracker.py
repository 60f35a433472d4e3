"""The RL tracker: a trained policy driving from the live :class:`~sim_core.observation.Observation`.

It builds the training observation (:func:`controllers.rl.observations.build_frame`, the very function the
trainer uses) from a one-race snapshot of the karts, stacks the last 4 frames, decides at 25 Hz (a decision
every 2 physics steps, holding the action in between, whatever rate it is called at) and maps the action
through the kart's longitudinal model (:func:`controllers.rl.actions.world_actions`).

What the live Observation does not carry is reconstructed here, the same way the referee computes it:

* the lane each kart is in now and the eq. (10) lane-change counter of the stretch (``I_LANE_NOW``,
  ``I_STEP_LANE_COUNT``): :func:`sim_core.referee.lane_with_hysteresis` and
  :func:`sim_core.rules.lane_change_update` on every decision (the referee updates them every physics step;
  a kart crossing two lanes within 40 ms is counted as one two-lane change either way);
* whether an opponent is on the accelerator: its speed rose since the last decision;
* the opponents' rays (only the ego's are observed; the frame uses the ego's alone);
* the elapsed-time feature: training episodes were one 30 s lap from a random spawn, so a race feeds the
  time since the kart's current lap began over 30 s, capped at 1 (race time would leave the trained range
  after 30 s).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from controllers.base import Action, ActionFilter, RaceContext
from controllers.plan import Plan
from controllers.rl.actions import ACCELERATE, world_actions
from controllers.rl.config import DECISION_STEPS, EPISODE_STEPS, SPEED_SCALE, STACK, AgentKind
from controllers.rl.observations import TrackTables, build_frame, frame_size, place_phantoms, race_karts
from controllers.rl.policy import Policy, load_policy, weights_folder
from controllers.rl.spawns import racing_lane_at_checkpoints
from sim_core import state as st
from sim_core.observation import Observation
from sim_core.params import DT, KartParams, RuleParams, SensorParams
from sim_core.referee import lane_with_hysteresis
from sim_core.rules import lane_change_update
from sim_core.world import World

DECISION_PERIOD = DECISION_STEPS * DT  # [s] 0.04: 25 Hz
LAP_TIME_SCALE = EPISODE_STEPS * DT  # [s] T of the time feature
HYSTERESIS = RuleParams().lane_hysteresis  # [m] the referee's lane membership


class _Snapshot:
    """The few World arrays :func:`build_frame` reads, for one race rebuilt from an Observation."""

    def __init__(self, n_karts: int, lane_change_limit: int, sensors: SensorParams) -> None:
        self.fstate = np.zeros((1, n_karts, st.N_FLOAT))
        self.istate = np.zeros((1, n_karts, st.N_INT), dtype=np.int64)
        self.ray_dist = np.full((1, n_karts, 9), sensors.max_range)
        self.lane_change_limit = lane_change_limit
        self.params = self  # build_frame reads params.sensors.max_range
        self.sensors = sensors


class RLTracker:
    """The tracker part of ``mcts-rl`` and ``fixed-rl``, and the whole of ``e2e`` (``plan`` is then ignored).

    ``agent`` picks how plans become targets, as in training: MCTS-RL targets the plan's lanes and speeds,
    Fixed-RL the plan's lanes at top speed, E2E the checkpoint centres at top speed. Checkpoints a plan does
    not cover fall back to the racing lane (planned agents) or the centre (E2E).

    The policy's action passes through ``filters`` in order (:mod:`controllers.rl.filters`: the shields and the
    stall recovery).

    By default (``deterministic``) it decides by the policy's Gaussian: the mean steer and the pedal branch the
    Gaussian most likely picks (:meth:`controllers.rl.policy.Policy.act`). Otherwise it samples the Gaussian, as
    PPO's rollouts do, with a generator seeded by the race (``context.seed``, ``context.ego``), so a seeded race
    is repeatable either way. Sampling drives slower: the steering noise costs speed through the tyres' limit.
    """

    def __init__(
        self,
        agent: AgentKind,
        folder: str | None = None,
        deterministic: bool = True,
        filters: Sequence[ActionFilter] = (),
    ) -> None:
        self.agent = agent
        self.filters = tuple(filters)
        self.folder = folder
        self.deterministic = deterministic
        self.rng = np.random.default_rng(0)
        self.policy: Policy | None = None
        self._ctx: RaceContext | None = None
        self.decisions = 0

    # ------------------------------------------------------------------ race setup
    def reset(self, context: RaceContext) -> None:
        """Load the weights (a clear :class:`~controllers.rl.policy.MissingWeightsError` if there are none) and
        prepare the track tables and the mirrored referee state."""
        self.policy = load_policy(self.folder or weights_folder(self.agent))
        for action_filter in self.filters:
            action_filter.reset(context)
        track, n = context.track, context.n_karts
        m = race_karts(self.policy.obs_size, STACK)  # karts of the trained races (2 for the shipped agents)
        if m is None:
            raise ValueError(f"{self.agent} weights take {self.policy.obs_size} floats: no race size gives that")
        self._ctx = context
        self.rng = np.random.default_rng([abs(context.seed), context.ego])
        self.kart: KartParams = context.kart
        self.tables = TrackTables.of(track)
        self.lane_offsets = np.ascontiguousarray(track.sample_lane_offsets(), dtype=np.float64)
        self.track = track
        self.straight = track.straight_flags.astype(bool)
        self.racing_lane = racing_lane_at_checkpoints(track)
        n_cp = track.n_checkpoints
        self.snap = _Snapshot(m, context.lane_change_limit, SensorParams())
        self.plan_lane = np.zeros((1, m, n_cp), dtype=np.int64)
        self.plan_speed = np.full((1, m, n_cp), context.kart.top_speed)
        self.accelerating = np.zeros((1, m))  # of the model race's karts (slot 0: the ego)
        self.opp_accelerating = np.zeros(n)  # of the race's karts
        self.lane_now = np.zeros(n, dtype=np.int64)  # 0: not yet known (the first decision takes the lane)
        self.lane_count = np.zeros(n, dtype=np.int64)
        self.passed = np.zeros(n, dtype=np.int64)
        self.last_speed = np.zeros(n)
        self.lap_start = 0.0
        self.stack = np.zeros((STACK, frame_size(m)))
        self.fresh = True
        self.next_decision = -np.inf
        self.action = Action(0.0, 0.0)
        self.decisions = 0

    # ------------------------------------------------------------------ deciding
    def act(self, observation: Observation, plan: Plan | None) -> Action:
        """A new decision every 40 ms of race time (the held one in between)."""
        if self.policy is None or self._ctx is None:
            raise RuntimeError("reset() first")
        if observation.time < self.next_decision - 1e-9:
            return self.action
        self.next_decision = observation.time + DECISION_PERIOD
        frame = self.frame(observation, plan)
        if self.fresh:
            self.stack[:] = frame
            self.fresh = False
        else:
            self.stack[:-1] = self.stack[1:]
            self.stack[-1] = frame
        raw = self.policy.act(self.stack.reshape(-1), None if self.deterministic else self.rng)
        me = observation.me
        inputs, branch = world_actions(self.kart, np.array([me.speed]), raw[None, :])
        self.accelerating[0, 0] = float(branch[0] == ACCELERATE)
        steer, throttle = inputs[0].tolist()
        self.action = Action(min(max(steer, -1.0), 1.0), min(max(throttle, -1.0), 1.0))
        for action_filter in self.filters:
            self.action = action_filter.apply(self.action, observation)
            if action_filter.took_over:  # a manoeuvre, not the policy's accelerator
                self.accelerating[0, 0] = 0.0
        self.decisions += 1
        return self.action

    def frame(self, observation: Observation, plan: Plan | None) -> np.ndarray:
        """The newest training frame of the ego kart (the accelerator flag is the previous decision's)."""
        self._snapshot(observation)
        self._targets(observation, plan)
        me = observation.me
        n_cp = self.tables.n_checkpoints
        if me.checkpoints_passed > 0 and me.checkpoints_passed % n_cp == 0 and me.crossing_time > self.lap_start:
            self.lap_start = me.crossing_time
        # a kart at a pace handicap sees its own time (speeds over pace x the trained unit, times times pace), in
        # which it drives as the trained kart does
        pace = self._ctx.pace if self._ctx is not None else 1.0
        time_fraction = np.array([min((observation.time - self.lap_start) * pace / LAP_TIME_SCALE, 1.0)])
        world = cast(World, self.snap)
        frames = build_frame(
            world, self.tables, self.plan_lane, self.plan_speed, self.accelerating, time_fraction, SPEED_SCALE * pace
        )
        return frames[0, 0]

    def _snapshot(self, observation: Observation) -> None:
        """Fill the model race: the ego in slot 0, then the nearest other karts still racing; missing ones
        (a solo race) are phantoms, finished karts 30 m behind the ego."""
        me = observation.me
        for view in observation.karts:
            self._update_lane(view.index, view.progress, view.lateral, view.checkpoints_passed, view.lane)
            if view.index != me.index:
                self.opp_accelerating[view.index] = float(view.speed > self.last_speed[view.index] + 1e-6)
            self.last_speed[view.index] = view.speed
        others = sorted(observation.others(), key=lambda v: (v.x - me.x) ** 2 + (v.y - me.y) ** 2)
        f, i = self.snap.fstate[0], self.snap.istate[0]
        absent = np.zeros((1, self.snap.fstate.shape[1]), dtype=bool)
        for slot in range(self.snap.fstate.shape[1]):
            seen = me if slot == 0 else (others[slot - 1] if slot - 1 < len(others) else None)
            if seen is None:  # a phantom (placed below, once the ego's slot is filled)
                absent[0, slot] = True
                self.accelerating[0, slot] = 0.0
                continue
            k = seen.index
            f[slot, st.F_X], f[slot, st.F_Y], f[slot, st.F_HEADING] = seen.x, seen.y, seen.heading
            f[slot, st.F_SPEED], f[slot, st.F_WEAR] = seen.speed, seen.wear
            f[slot, st.F_S], f[slot, st.F_D] = seen.progress, seen.lateral
            i[slot, st.I_CP_PASSED], i[slot, st.I_FINISHED] = seen.checkpoints_passed, int(seen.finished)
            i[slot, st.I_LANE_NOW], i[slot, st.I_STEP_LANE_COUNT] = self.lane_now[k], self.lane_count[k]
            if slot:
                self.accelerating[0, slot] = self.opp_accelerating[k]
        place_phantoms(self.snap.fstate, self.snap.istate, absent)
        self.snap.ray_dist[0, 0] = observation.ray_distances

    def _update_lane(self, k: int, s: float, d: float, passed: int, crossing_lane: int) -> None:
        """The referee's lane membership and eq. (10) counter, on this decision."""
        row = self.track.sample_at(s)
        if self.lane_now[k] < 1:
            first = lane_with_hysteresis(self.lane_offsets, row, d, 0, HYSTERESIS)
            self.lane_now[k] = crossing_lane if crossing_lane >= 1 else first
            self.passed[k] = passed
            return
        lane = lane_with_hysteresis(self.lane_offsets, row, d, int(self.lane_now[k]), HYSTERESIS)
        n, limit = self.tables.n_checkpoints, self.snap.lane_change_limit
        if passed != self.passed[k]:  # a new section first (the counter resets between road types) ...
            straight_before, straight_now = bool(self.straight[self.passed[k] % n]), bool(self.straight[passed % n])
            if straight_before != straight_now:
                self.lane_count[k] = 0
            self.passed[k] = passed
        if lane != self.lane_now[k]:  # ... then the lane change, within it
            here = bool(self.straight[passed % n])
            count, _ = lane_change_update(int(self.lane_count[k]), int(self.lane_now[k]), lane, here, here, limit)
            self.lane_count[k], self.lane_now[k] = count, lane

    def _targets(self, observation: Observation, plan: Plan | None) -> None:
        """The ego's target lane (0 = centre) and speed per checkpoint, from the plan as in training."""
        ego, n_cp, top = 0, self.tables.n_checkpoints, self.kart.top_speed
        if self.agent == "e2e":
            return  # checkpoint centres at top speed (the reset values)
        self.plan_lane[0, ego] = self.racing_lane
        self.plan_speed[0, ego] = top
        if plan is None:
            return
        for waypoint in plan.ego_waypoints:
            c = waypoint.checkpoint % n_cp
            self.plan_lane[0, ego, c] = waypoint.lane
            if self.agent == "mcts-rl":
                self.plan_speed[0, ego, c] = min(waypoint.speed, top)
