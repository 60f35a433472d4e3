"""A recorded race re-simulated from its replay (controllers.timeline) is the race that ran: the same poses,
and the referee's counters and incidents add up to its result."""

from __future__ import annotations

import itertools
from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from controllers.race import RaceOutcome, RaceSpec, load_any_track, run_race
from controllers.timeline import (
    COLLISION_AT_FAULT,
    ILLEGAL_LANE_CHANGE,
    PASS,
    WALL_HIT,
    RaceTimeline,
    resimulate,
    running_order,
)
from sim_core.params import SimParams, kart_preset

SPEC = RaceSpec(track="oval", controllers=("mcts-lqng", "lane-follower"), laps=2, seed=3, start_lanes=(3, 2))


@pytest.fixture(scope="module")
def recorded() -> tuple[RaceOutcome, RaceTimeline]:
    """A seeded two-lap race with a collision and a pass, and its re-simulation."""
    outcome = run_race(SPEC, record=True)
    assert outcome.replay is not None
    poses = np.asarray(outcome.replay.poses)
    timeline = resimulate(poses, load_any_track("oval"), 2, SimParams(kart=kart_preset("paper")), SPEC.start_lanes)
    return outcome, timeline


def test_the_re_simulation_follows_the_recorded_poses(recorded: tuple[RaceOutcome, RaceTimeline]) -> None:
    outcome, timeline = recorded
    assert outcome.replay is not None
    assert timeline.pose_error == 0.0
    assert timeline.steps == len(outcome.replay.poses)
    assert timeline.x[1:].tolist() == [[kart[0] for kart in step] for step in outcome.replay.poses]


def test_counters_and_incidents_add_up_to_the_result(recorded: tuple[RaceOutcome, RaceTimeline]) -> None:
    outcome, timeline = recorded
    kinds = Counter((incident.kart, incident.kind) for incident in timeline.incidents)
    assert any(kind in (COLLISION_AT_FAULT, PASS) for _, kind in kinds)  # the seed gives a race with incidents
    for kart in outcome.result.karts:
        k = kart.kart
        assert timeline.finish_time[k] == kart.finish_time
        assert timeline.checkpoints_passed[-1, k] == kart.checkpoints_passed
        assert timeline.position[-1, k] == kart.position
        assert timeline.collisions_at_fault[-1, k] == kart.collisions_at_fault == kinds[k, COLLISION_AT_FAULT]
        assert timeline.illegal_lane_changes[-1, k] == kart.illegal_lane_changes == kinds[k, ILLEGAL_LANE_CHANGE]
        assert timeline.wall_hits[-1, k] == kart.wall_hits == kinds[k, WALL_HIT]
        assert timeline.passes[-1, k] == kart.passes == kinds[k, PASS]
        crossings = [c for c in timeline.crossings if c.kart == k]
        assert [c.checkpoint for c in crossings] == list(range(1, kart.checkpoints_passed + 1))
        assert all(a.time < b.time for a, b in itertools.pairwise(crossings))
        if kart.finished:
            assert crossings[-1].time == kart.finish_time
    for incident in timeline.incidents:
        if incident.kind == PASS:
            assert incident.other is not None and incident.other != incident.kart
    assert [i.time for i in timeline.incidents] == sorted(i.time for i in timeline.incidents)


def test_running_order_by_hand() -> None:
    progress = np.array([[5.0, 3.0, 4.0], [50.0, 60.0, 40.0]])
    finished = np.array([[False, False, False], [True, True, False]])
    # row 0: by progress; row 1: karts 0 and 1 finished (kart 1 first: 9 s against 10 s), kart 2 last
    assert running_order(progress, finished, (10.0, 9.0, None)).tolist() == [[1, 3, 2], [2, 1, 3]]


def test_poses_of_the_wrong_shape_are_refused() -> None:
    with pytest.raises(ValueError, match="poses must have shape"):
        resimulate(np.zeros((10, 2, 4)), load_any_track("oval"), 1, SimParams())


def test_a_race_under_drawn_conditions_re_simulates_exactly_with_them() -> None:
    """Under varied-equal-distance (drawn start wear, the drivers' noise in the recorded inputs, each kart finishing
    3 m past the line): with its conditions the re-simulation is the race; under the paper's it strays."""
    spec = RaceSpec(track="oval", controllers=("fixed-lqng", "lane-follower"), laps=1, seed=5)
    outcome = run_race(replace(spec, conditions="varied-equal-distance"), record=True)
    assert outcome.replay is not None and outcome.conditions is not None
    poses, track, params = np.asarray(outcome.replay.poses), load_any_track("oval"), SimParams()
    timeline = resimulate(poses, track, 1, params, None, outcome.conditions)
    assert timeline.pose_error == 0.0
    assert list(timeline.finish_time) == [k.finish_time for k in outcome.result.karts]
    paper = resimulate(poses, track, 1, params)
    assert paper.pose_error > 0.0 and list(paper.finish_time) != list(timeline.finish_time)


def test_karts_at_a_pace_re_simulate_exactly_at_that_pace() -> None:
    """varied-pace draws each kart's pace; the second kart is also handicapped to 0.9 by its agent string."""
    spec = RaceSpec("oval", ("fixed-lqng", "lane-follower@0.9"), laps=1, seed=5, conditions="varied-pace")
    outcome = run_race(spec, record=True)
    assert outcome.replay is not None and outcome.conditions is not None
    poses, track, params = np.asarray(outcome.replay.poses), load_any_track("oval"), SimParams()
    paces = spec.kart_paces(outcome.conditions)
    assert paces[1] < 0.9
    assert resimulate(poses, track, 1, params, None, outcome.conditions, paces).pose_error == 0.0
    assert resimulate(poses, track, 1, params, None, outcome.conditions).pose_error > 0.0  # drawn paces alone
