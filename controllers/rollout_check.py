"""A tactical plan checked by racing it (ours, not the paper's): the MCTS plan's next few lanes against others,
each raced forward a few seconds in a private copy of the simulator before the plan is sent. A part, not in any
registered agent's default (docs/agents.md says why).

The discrete game times a lane choice with a lane-radius model calibrated to the racing line; it does not see what
the LQ tracker and the other kart will make of it. In the first corner of ``complex`` that is the race: from the
outside start lane, holding the inside lane through checkpoints 7-9 while the kart ahead drifts out with the racing
line passes it with no contact, and following the line loses (a search that raced every lane sequence in the
simulator found the move; the MCTS never chose it).

:class:`RolloutCheck` races candidate lanes for the ``depth`` checkpoints after the committed next one: every lane
sequence (``exhaustive``) or the search's, the racing line's and each lane held, those the lane-change rule allows.
The ego drives its own tracker; the kart ahead drives the rival tracker (``rival_tracker``, a model of that kart)
on the lanes the plan predicts for it. A candidate scores the seconds by which the ego crosses the checkpoint
``settle`` past the window ahead of that kart, less ``penalty`` per contact, collision at fault or illegal lane
change in the rollout; the best replaces the search's lanes when it gains ``margin``.
:class:`~controllers.checked_planner.CheckedPlanner` puts the check behind an
:class:`~controllers.tactical.high_level.MCTSPlanner` in the high-level slot.

The check is only as good as its model of the other kart. With fixed-lqng's own tracker as the model it won every
start against fixed-lqng on ``complex``, and against any other driver its model missed by a metre or more a second
ahead: it raced the wrong kart and collided. A trust gate (``trust_miss``) races a kart only while a racing-line
follower predicts it; that makes the check a model of one registered opponent's code, which is why no registered
agent uses it. A general opponent model chosen per kart by measured prediction error is the seam it waits for.

Its cost is the rollouts: every candidate is ``max_steps`` steps at most of two LQ trackers. Candidates that share
their first lanes are raced once up to where they part (:meth:`RolloutCheck.scores`), and an exhaustive check of
depth 3 (64 candidates) takes about 2 s on the 2-core machine (``benchmarks/rollout_check.py``), against 10-40 ms
for the search.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from controllers.base import RaceContext
from controllers.fixed_line import FixedLinePlanner
from controllers.lq.tracker import LQNGTracker
from controllers.lq.traffic import PassDetector
from controllers.plan import Plan, Waypoint
from controllers.tactical.high_level import lanes_legal
from sim_core import state as st
from sim_core.observation import KartView, Observation, observe, place_view
from sim_core.params import DT, SimParams
from sim_core.world import World

TrackerFactory = Callable[[], LQNGTracker]


@dataclass(frozen=True)
class RolloutCheckSettings:
    """What a check races and how it judges (see the module note)."""

    depth: int = 3  # checkpoints after the committed next one
    settle: int = 2  # the race is judged at the checkpoint this many past the window
    reach: float = 25.0  # [m] a kart ahead within this along the track is raced against
    behind: float = 3.0  # [m] ... or one this little behind (alongside)
    margin: float = 0.05  # [s] a candidate replaces the search's lanes when it gains this much
    penalty: float = 1000.0  # [s] per contact, collision at fault or illegal lane change in a rollout
    max_steps: int = 450  # steps of 0.02 s at most per rollout
    exhaustive: bool = True  # every lane sequence; False: the search's, the racing line's and each lane held
    # trust: at every plan the check races each other kart from the previous plan's observation to now, the ego on
    # the plan it sent and the other kart as a racing-line follower (fixed-lqng's planner and tracker), and measures
    # how far that misses where the kart really is. A kart is raced against only once measured, and while the
    # median of its last ``trust_samples`` misses is at most ``trust_miss`` [m] (0: no gate, every kart raced).
    # On complex the follower misses fixed-lqng by 0.00-0.05 m a second on (rarely up to 0.5 m) and the RL agents
    # by 0.2-4 m. See :meth:`RolloutCheck.trusts`
    trust_miss: float = 0.0
    trust_samples: int = 3
    # [s] the plan is applied this long after the observation it answers: the rollouts first race the plan sent
    # before for that long, then the candidates (at 0.3 s of delay and 0 here the lane-2 start on complex against
    # fixed-lqng was lost). A live host's budget (CheckedPlanner.plan_budget_s) replaces it
    lead_s: float = 0.0

    def __post_init__(self) -> None:
        if self.depth < 1 or self.settle < 0 or self.max_steps < 1:
            raise ValueError("depth must be >= 1, settle >= 0 and max_steps >= 1")
        if self.trust_miss < 0.0 or self.trust_samples < 1:
            raise ValueError("trust_miss must be >= 0 and trust_samples >= 1")


@dataclass
class CheckCounts:
    """How often a planner checked and changed its plans in a race, and the rollouts it raced."""

    plans: int = 0
    checked: int = 0
    changed: int = 0
    rollouts: int = 0  # candidates scored
    steps: int = 0  # simulation steps raced for them (and for the misses)
    untrusted: int = 0  # plans with a kart in reach that the check left alone: its model missed that kart
    misses: list[tuple[float, int, float]] = field(default_factory=list)  # (time [s], kart, miss [m]) per plan
    changed_at: list[float] = field(default_factory=list)  # race times [s] of the plans the check changed
    cut: int = 0  # candidates left unscored because a plan's wall-clock budget ran out (live races only)


class RolloutCheck:
    """Races candidate ego lanes forward from an observation against the nearest kart ahead (module note)."""

    def __init__(
        self, settings: RolloutCheckSettings, ego_tracker: TrackerFactory, rival_tracker: TrackerFactory
    ) -> None:
        self.settings = settings
        self.ego_tracker = ego_tracker
        self.rival_tracker = rival_tracker
        self.counts = CheckCounts()
        self._context: RaceContext | None = None
        self._world: World | None = None
        self._trackers: tuple[LQNGTracker, LQNGTracker] | None = None
        self._previous: tuple[Observation, Plan] | None = None  # the previous check's observation and plan sent
        self._misses: dict[int, list[float]] = {}  # per other kart: the model's misses [m], oldest first
        self._follower = FixedLinePlanner()  # the racing-line follower that measures how the other karts drive
        self.deadline: float | None = None  # time.perf_counter() after which no new branch is raced (None: none)
        self.lead_s = settings.lead_s  # [s] see RolloutCheckSettings.lead_s

    def reset(self, context: RaceContext) -> None:
        """A private two-kart world on the race's track (no sensors) and the two trackers the rollouts drive."""
        self._context = context
        self._world = World(context.track, 1, 2, SimParams(kart=context.kart), sensors=False)
        trackers = (self.ego_tracker(), self.rival_tracker())
        for slot, tracker in enumerate(trackers):
            tracker.reset(RaceContext(context.track, context.kart, slot, 2, context.lane_change_limit, context.seed))
        self._trackers = trackers
        self.counts = CheckCounts()
        self._previous = None
        self._misses = {}
        self._follower.reset(context)

    def measure(self, observation: Observation) -> None:
        """Race every other kart that was within ``2 * reach`` along the track at the previous plan from that plan's
        observation to ``observation``'s time, the ego on the plan it sent and the other kart as a racing-line
        follower, and keep how far that misses where it is now.

        Why a line follower and not the lanes the search predicts for it (what the rollouts race): the check's
        model was fixed-lqng, and on predicted lanes it misses fixed-lqng itself by 0.5-0.6 m a second ahead on
        average, about half as much as the RL agents (1.0-1.3 m), too close to tell them apart; as the line
        follower it is, fixed-lqng is predicted to about 0.1 m."""
        if self._previous is None:
            return
        assert self._context is not None and self._world is not None, "reset() first"
        before, plan = self._previous
        steps = round((observation.time - before.time) / DT)
        if not 0 < steps <= self.settings.max_steps:
            return
        now = {k.index: k for k in observation.others()}
        track, me = self._context.track, before.me
        for then in before.others():
            kart = now.get(then.index)
            if kart is None or abs(track.gap(me.progress, then.progress)) > 2.0 * self.settings.reach:
                continue
            follower = self._follower.plan(replace(before, ego=then.index)).ego_waypoints
            raced = replace(plan, waypoints={**plan.waypoints, then.index: follower})
            rollout = self._begin(before, then, raced)
            self._advance(raced, rollout, 1 << 30, None, limit=steps)
            x, y = self._world.positions[0, 1]
            miss = float(np.hypot(x - kart.x, y - kart.y))
            self._misses.setdefault(kart.index, []).append(miss)
            self.counts.misses.append((observation.time, kart.index, miss))

    def trusts(self, kart: int) -> bool:
        """Whether the check races against ``kart``: always with ``trust_miss`` 0, else once measured and while
        the median of the follower's last ``trust_samples`` misses on it is at most ``trust_miss``."""
        if self.settings.trust_miss <= 0.0:
            return True
        recent = self._misses.get(kart, [])[-self.settings.trust_samples :]
        return bool(recent) and float(np.median(recent)) <= self.settings.trust_miss

    def rival(self, observation: Observation) -> KartView | None:
        """The kart nearest along the track that is ahead within ``reach`` or alongside; None: nobody."""
        assert self._context is not None, "reset() first"
        track, me = self._context.track, observation.me
        nearest: KartView | None = None
        for kart in observation.others():
            gap = track.gap(me.progress, kart.progress)
            if -self.settings.behind < gap < self.settings.reach and (
                nearest is None or abs(gap) < abs(track.gap(me.progress, nearest.progress))
            ):
                nearest = kart
        return nearest

    def candidates(
        self, plan: Plan, me: KartView, line_lanes: tuple[int, ...], lane_limit: int
    ) -> list[tuple[int, ...]]:
        """Lane sequences for the window (the ego's waypoints after its first), the search's first, that the
        lane-change rule allows from the ego's last crossing with the rest of the plan unchanged."""
        assert self._context is not None, "reset() first"
        track = self._context.track
        waypoints = plan.ego_waypoints
        window = waypoints[1 : 1 + self.settings.depth]
        searched = tuple(w.lane for w in window)
        if self.settings.exhaustive:
            pool = list(itertools.product(range(1, track.n_lanes + 1), repeat=len(window)))
        else:
            pool = [tuple(line_lanes[w.checkpoint % track.n_checkpoints] for w in window)]
            pool += [(lane,) * len(window) for lane in range(1, track.n_lanes + 1)]
        chosen = [searched]
        for lanes in pool:
            if lanes in chosen:
                continue
            if lanes_legal(track, me.lane, me.lane_changes, list(self.with_lanes(waypoints, lanes)), lane_limit):
                chosen.append(lanes)
        return chosen

    def with_lanes(self, waypoints: tuple[Waypoint, ...], lanes: tuple[int, ...]) -> tuple[Waypoint, ...]:
        """``waypoints`` with the window's lanes (those after the first) set to ``lanes``."""
        assert self._context is not None, "reset() first"
        track = self._context.track
        changed = list(waypoints)
        for i, lane in enumerate(lanes, start=1):
            w = waypoints[i]
            if w.lane != lane:
                point = track.lane_point(w.checkpoint % track.n_checkpoints, lane)
                changed[i] = replace(w, lane=lane, position=(float(point[0]), float(point[1])))
        return tuple(changed)

    def score(self, observation: Observation, rival: KartView, plan: Plan, target: int) -> float:
        """Seconds by which the ego crosses checkpoint ``target`` ahead of ``rival``, both driving ``plan`` (the
        ego its waypoints, the rival those predicted for it) from where ``observation`` saw them, less
        ``penalty`` per contact, collision at fault or ego's illegal lane change on the way."""
        self.counts.rollouts += 1
        rollout = self._begin(observation, rival, plan)
        self._advance(plan, rollout, target, None)
        return self._judge(rollout)

    def _begin(self, observation: Observation, rival: KartView, plan: Plan) -> _Rollout:
        """The private world placed at ``observation``'s ego and ``rival`` (slots 0 and 1), each tracker steering
        what it asks for there."""
        assert self._world is not None and self._trackers is not None, "reset() first"
        world, trackers = self._world, self._trackers
        world.clear_race(0)
        rollout_plan = self._rollout_plan(plan, observation.ego, rival.index)
        for slot, view in enumerate((observation.me, rival)):
            place_view(world, 0, slot, view)
        # each tracker starts steering what it asks for now (its steering is rate-limited): from straight ahead a
        # kart seen mid-corner runs wide and every candidate touches the other kart
        views = observe(world, 0)
        for slot, tracker in enumerate(trackers):
            place_view(world, 0, slot, views[slot].me, tracker.start_steering(views[slot], rollout_plan))
        return _Rollout(ego=observation.ego, rival=rival.index)

    @staticmethod
    def _rollout_plan(plan: Plan, ego: int, rival: int) -> Plan:
        """``plan`` with the ego's waypoints as slot 0's and the rival's as slot 1's (the private world's karts)."""
        return replace(plan, ego=0, waypoints={0: plan.waypoints.get(ego, ()), 1: plan.waypoints.get(rival, ())})

    def _advance(
        self, plan: Plan, rollout: _Rollout, target: int, until_passed: int | None, limit: int | None = None
    ) -> bool:
        """Race ``plan`` on from where ``rollout`` stands until both karts have crossed checkpoint ``target``, the
        race is over or ``limit`` steps (by default ``max_steps``) are spent (True), or until the ego has passed
        checkpoint ``until_passed`` (False: from there on, plans that differ only in later lanes drive
        differently)."""
        assert self._world is not None and self._trackers is not None, "reset() first"
        world, trackers = self._world, self._trackers
        rollout_plan = self._rollout_plan(plan, rollout.ego, rollout.rival)
        crossed = rollout.crossed
        actions = np.zeros((1, 2, 2))
        end = self.settings.max_steps if limit is None else limit
        while rollout.step < end:
            views = observe(world, 0)
            for slot, tracker in enumerate(trackers):
                action = tracker.act(views[slot], rollout_plan)
                actions[0, slot] = (action.steer, action.throttle)
            world.step(actions)
            self.counts.steps += 1
            for slot in (0, 1):
                if crossed[slot] < 0 and (
                    world.istate[0, slot, st.I_CP_PASSED] >= target or world.istate[0, slot, st.I_FINISHED]
                ):
                    crossed[slot] = rollout.step
            rollout.step += 1
            if min(crossed) >= 0 or bool(world.done[0]):
                return True
            if until_passed is not None and world.istate[0, 0, st.I_CP_PASSED] >= until_passed:
                return False
        return True

    def _judge(self, rollout: _Rollout) -> float:
        """The score of a finished rollout (see :meth:`score`)."""
        assert self._world is not None, "reset() first"
        ego_step, rival_step = (self.settings.max_steps if c < 0 else c for c in rollout.crossed)
        state = self._world.istate[0]
        mishaps = int(state[:, st.I_CONTACTS].sum() + state[:, st.I_FAULTS].sum() + state[0, st.I_ILLEGAL])
        return DT * (rival_step - ego_step) - self.settings.penalty * mishaps

    def scores(
        self, observation: Observation, rival: KartView, plan: Plan, target: int, candidates: list[tuple[int, ...]]
    ) -> dict[tuple[int, ...], float]:
        """:meth:`score` of each candidate (window lanes for ``plan``'s ego), in ``candidates``' order, raced as a
        tree: the trackers see the plan only through each kart's next two waypoints, so candidates that share
        their first k lanes drive alike until the ego has passed the k-th waypoint of the plan (the committed
        next one first); that part is raced once, and each branch goes on from a copy of the world. The same
        numbers as racing each candidate alone (a test checks it), at about three quarters of the steps.

        Exact only while the rival's tracker does not look past the ego's next two waypoints
        (a :class:`~controllers.lq.traffic.PassDetector` ``on_prediction`` reads the ego's lanes where the rival is):
        such a rival races each alone.

        Past :attr:`deadline` no new branch is raced but the one of the search's own lanes (the first candidate):
        the candidates left unscored are missing from the result."""
        if any(isinstance(rule, PassDetector) and rule.on_prediction for rule in self._rival_rules()):
            return {
                lanes: self.score(observation, rival, self.with_lanes_plan(plan, lanes), target) for lanes in candidates
            }
        waypoints = plan.ego_waypoints
        found: dict[tuple[int, ...], float] = {}

        def explore(group: list[tuple[int, ...]], shared: int, saved: _Saved | None) -> None:
            branches: dict[tuple[int, ...], list[tuple[int, ...]]] = {}
            for lanes in group:
                branches.setdefault(lanes[: shared + 1], []).append(lanes)
            for members in branches.values():
                if self._past_deadline() and candidates[0] not in members:
                    self.counts.cut += len(members)
                    continue
                candidate = self.with_lanes_plan(plan, members[0])
                rollout = self._begin(observation, rival, candidate) if saved is None else self._restore(saved)
                last = shared + 1 == len(members[0])
                split_at = None if last else waypoints[shared].checkpoint
                if self._advance(candidate, rollout, target, split_at) or last:
                    value = self._judge(rollout)
                    for lanes in members:
                        found[lanes] = value
                else:
                    explore(members, shared + 1, self._save(rollout))

        explore(candidates, 0, None)
        self.counts.rollouts += len(found)
        return {lanes: found[lanes] for lanes in candidates if lanes in found}

    def _rival_rules(self) -> tuple[object, ...]:
        assert self._trackers is not None, "reset() first"
        return self._trackers[1].rules

    def _past_deadline(self) -> bool:
        return self.deadline is not None and time.perf_counter() > self.deadline

    def with_lanes_plan(self, plan: Plan, lanes: tuple[int, ...]) -> Plan:
        """``plan`` with its ego's window lanes set to ``lanes`` (:meth:`with_lanes`)."""
        return replace(plan, waypoints={**plan.waypoints, plan.ego: self.with_lanes(plan.ego_waypoints, lanes)})

    def _save(self, rollout: _Rollout) -> _Saved:
        assert self._world is not None and self._trackers is not None, "reset() first"
        steers = tuple(tracker.last_steer for tracker in self._trackers)
        return _Saved(self._world.state_arrays(), steers, replace(rollout, crossed=list(rollout.crossed)))

    def _restore(self, saved: _Saved) -> _Rollout:
        assert self._world is not None and self._trackers is not None, "reset() first"
        self._world.restore_state(saved.world)
        for tracker, steer in zip(self._trackers, saved.steers, strict=True):
            tracker.last_steer = steer
        return replace(saved.rollout, crossed=list(saved.rollout.crossed))

    def check(self, observation: Observation, plan: Plan, line_lanes: tuple[int, ...], lane_limit: int) -> Plan:
        """``plan``, or ``plan`` with the window's lanes of the best candidate when it gains ``margin``; with
        ``trust_miss``, first the model's misses since the previous plan (:meth:`measure`), and a kart ahead it
        does not :meth:`trusts` leaves the plan alone."""
        if self.settings.trust_miss > 0.0:
            self.measure(observation)
        checked = self._checked(observation, plan, line_lanes, lane_limit)
        self._previous = (observation, checked)
        return checked

    def ahead(self, observation: Observation, rival: KartView, sent: Plan, steps: int) -> Observation:
        """``observation`` with the ego and ``rival`` raced ``steps`` on, both on ``sent`` (the plan the ego drives
        until the new one arrives); the other karts as they were."""
        assert self._world is not None, "reset() first"
        rollout = self._begin(observation, rival, sent)
        self._advance(sent, rollout, 1 << 30, None, limit=steps)
        views = observe(self._world, 0)
        karts = {k.index: k for k in observation.karts}
        karts[observation.ego] = replace(views[0].me, index=observation.ego)
        karts[rival.index] = replace(views[1].me, index=rival.index)
        ordered = tuple(karts[k.index] for k in observation.karts)
        return replace(observation, time=observation.time + steps * DT, karts=ordered)

    def _checked(self, observation: Observation, plan: Plan, line_lanes: tuple[int, ...], lane_limit: int) -> Plan:
        self.counts.plans += 1
        rival = self.rival(observation)
        waypoints = plan.ego_waypoints
        if rival is None or len(waypoints) < self.settings.depth + 1:
            return plan
        if not self.trusts(rival.index):
            self.counts.untrusted += 1
            return plan
        self.counts.checked += 1
        target = waypoints[self.settings.depth].checkpoint + self.settings.settle
        candidates = self.candidates(plan, observation.me, line_lanes, lane_limit)
        start, lead = observation, round(self.lead_s / DT)
        if lead > 0 and self._previous is not None:
            start = self.ahead(observation, rival, self._previous[1], lead)
            rival = next(k for k in start.karts if k.index == rival.index)
        scores = self.scores(start, rival, plan, target, candidates)
        searched = candidates[0]
        best = max(scores, key=lambda lanes: scores[lanes])
        if scores[best] < scores[searched] + self.settings.margin:
            return plan
        self.counts.changed += 1
        self.counts.changed_at.append(observation.time)
        return self.with_lanes_plan(plan, best)


@dataclass
class _Rollout:
    """Where a rollout stands: the karts it races (their indices in the observed race), the steps raced and the
    step at which each crossed the target checkpoint (-1: not yet)."""

    ego: int
    rival: int
    step: int = 0
    crossed: list[int] = field(default_factory=lambda: [-1, -1])


@dataclass(frozen=True)
class _Saved:
    """A rollout's branching point: the private world's state arrays, the trackers' last steers, the rollout."""

    world: dict[str, np.ndarray]
    steers: tuple[float, ...]
    rollout: _Rollout
