"""The LQNG tracker in races: in a real duel the tactical driver's steer input never changes faster than its
preset's rate, while the same duel without the limit does (so the limit is what holds it); and its speed scale, a
handicapped kart's top speed. Each traffic rule alone: test_lq_traffic.py."""

from __future__ import annotations

import numpy as np

from controllers.base import Action, RaceContext
from controllers.hierarchical import HierarchicalController
from controllers.lq.presets import MCTS_TRAFFIC
from controllers.lq.tracker import LQNGTracker
from controllers.lq.traffic import SteerRateLimit
from controllers.plan import Plan
from controllers.race import RaceSpec, run_race
from controllers.registry import make_controller
from sim_core.observation import Observation, observe
from sim_core.params import DT, PAPER_KART
from sim_core.world import World


class RecordingTracker:
    """An LQNG tracker that keeps every steer input it returns."""

    def __init__(self, inner: LQNGTracker) -> None:
        self.inner = inner
        self.steers: list[float] = []

    def reset(self, context: RaceContext) -> None:
        self.inner.reset(context)

    def act(self, observation: Observation, plan: Plan | None) -> Action:
        action = self.inner.act(observation, plan)
        self.steers.append(action.steer)
        return action


def _steer_rates(limited: bool) -> np.ndarray:
    """Steer input changes per second of mcts-lqng over the first 10 s of a complex duel (seed 0, lane 2), with or
    without its steer-rate limit."""
    driver = make_controller("mcts-lqng")
    assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
    tracker = driver.tracker
    rules = tracker.rules if limited else tuple(r for r in tracker.rules if not isinstance(r, SteerRateLimit))
    recorder = RecordingTracker(LQNGTracker(tracker.params, rules))
    driver.tracker = recorder
    spec = RaceSpec(
        track="complex", controllers=("mcts-lqng", "fixed-lqng"), seed=0, start_lanes=(2, 3), time_limit=10.0
    )
    run_race(spec, drivers=[driver, make_controller("fixed-lqng")])
    assert len(recorder.steers) >= 400
    return np.abs(np.diff(recorder.steers)) / DT


def test_the_tactical_tracker_rate_limits_its_steering_in_traffic() -> None:
    rate = next(r.rate for r in MCTS_TRAFFIC if isinstance(r, SteerRateLimit))
    assert _steer_rates(limited=True).max() <= rate + 1e-9
    assert _steer_rates(limited=False).max() > rate


def _top_speed(agent: str) -> float:
    """The highest speed [m/s] ``agent`` reaches in a lap of the oval alone."""
    fastest = [0.0]

    def record(world: World, drivers: object, step: int) -> None:
        fastest[0] = max(fastest[0], observe(world, 0)[0].me.speed)

    run_race(RaceSpec(track="oval", controllers=(agent,), laps=1, seed=0), on_step=record)
    return fastest[0]


def test_a_kart_at_a_pace_handicap_keeps_to_its_lower_top_speed_and_uses_most_of_it() -> None:
    assert _top_speed("fixed-lqng") > 0.97 * PAPER_KART.top_speed
    assert 0.97 * 0.8 * PAPER_KART.top_speed < _top_speed("fixed-lqng@0.8") <= 0.8 * PAPER_KART.top_speed


def test_the_tracker_tables_have_one_type_wherever_the_track_was_built() -> None:
    """A controller host gets its track unpickled (cached arrays writable) while the process that built it has them
    read-only: the tables must type the same in both, or numba compiles the tracker's kernels again, mid-race."""
    import pickle

    import numba

    from controllers.lq.targets import TrackerTables
    from controllers.racing_line import optimise_racing_line
    from sim_core.track_io import get_track

    track = get_track("oval")
    line = optimise_racing_line(track, PAPER_KART)
    _ = track.segments  # computed (read-only) before pickling, as the server's track has them
    unpickled = pickle.loads(pickle.dumps(track))
    assert unpickled.segments[2].flags.writeable != track.segments[2].flags.writeable  # what made them differ
    here, there = TrackerTables.of(track, line), TrackerTables.of(unpickled, line)
    for name in TrackerTables.__dataclass_fields__:
        assert numba.typeof(getattr(here, name)) == numba.typeof(getattr(there, name)), name
