"""Referee scenarios with hand-checked outcomes: laps and finish, winner, DNF and the time limit, plan-following
metrics, wall hits, safety buffers and sensors."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.lane_follower import LaneFollower
from sim_core import state as st
from sim_core.params import RuleParams, SimParams
from sim_core.track_io import get_track
from sim_core.world import World


def drive(world: World, follower: LaneFollower, lateral: np.ndarray, stopped: tuple[int, ...] = ()) -> None:
    while not world.done.all():
        actions = follower.act_on(world, lateral)
        for k in stopped:
            actions[:, k] = (0.0, -1.0)
        world.step(actions)


def test_finish_winner_and_dnf() -> None:
    track = get_track("train-oval-small")
    params = SimParams(rules=RuleParams(time_limit=40.0))
    world = World(track, 1, 2, params, laps=1)
    drive(world, LaneFollower(track, params.kart), np.array([[1.25, -1.25]]), stopped=(1,))
    result = world.result(0)
    assert result.done
    assert result.winner == 0
    assert result.karts[0].finished and result.karts[0].laps_completed == 1
    assert result.karts[0].checkpoints_passed == track.n_checkpoints
    # a lap of ~194 m minus the 3 m grid offset takes more than 194/15 s
    assert 191.0 / 15.0 < result.karts[0].finish_time < 40.0
    assert not result.karts[1].finished and result.karts[1].finish_time is None
    assert result.duration == pytest.approx(40.0)
    assert [kr.position for kr in result.karts] == [1, 2]


def test_nobody_wins_when_nobody_finishes() -> None:
    track = get_track("oval")
    world = World(track, 1, 2, SimParams(rules=RuleParams(time_limit=2.0)))
    world.step(np.tile([0.0, 1.0], (1, 2, 1)), n_steps=200)
    result = world.result(0)
    assert result.done and result.winner is None
    assert world.steps[0] == 100  # the race stops at the limit


def test_finish_time_is_interpolated_within_the_step() -> None:
    track = get_track("train-oval-small")
    world = World(track, 1, 1, laps=1, sensors=False)
    drive(world, LaneFollower(track, world.params.kart), np.array([[0.0]]))
    t = world.result(0).karts[0].finish_time
    assert t is not None and world.time[0] - 0.02 < t <= world.time[0]


def test_plan_following_metrics() -> None:
    track = get_track("oval")
    world = World(track, 1, 1, sensors=False)  # starts in lane 2 (+1.25 m)
    world.set_target(0, 0, 1, lane=4, speed=10.0)
    world.set_target(0, 0, 2, lane=2, speed=None)
    actions = np.array([[[0.0, 1.0]]])
    while world.istate[0, 0, st.I_CP_PASSED] < 2:
        world.step(actions)
    result = world.result(0).karts[0]
    # checkpoint 1: |1.25 - (-3.5)| - 1.3 dead zone; checkpoint 2: on target -> 0
    assert result.delta_r == pytest.approx((4.75 - 1.3 + 0.0) / 2, abs=0.02)
    v_at_cp1 = np.sqrt(2 * 4.0 * (track.checkpoint_s[1] - 3.0))
    assert result.delta_v == pytest.approx(abs(v_at_cp1 - 10.0), abs=0.1)


def test_wall_hit_is_counted_once_per_contact() -> None:
    track = get_track("oval")
    world = World(track, 1, 1, sensors=False)
    actions = np.array([[[0.4, 1.0]]])  # veer left into the wall and keep pushing
    touching = []
    for _ in range(150):
        world.step(actions)
        touching.append(int(world.istate[0, 0, st.I_WALL_CONTACT]))
    # the kart grinds along the wall (touching, pushed off, turning back in): one hit
    assert sum(touching[-50:]) >= 10
    assert world.istate[0, 0, st.I_WALL_HITS] == 1


def test_buffer_violation_when_directly_behind() -> None:
    track = get_track("oval")
    world = World(track, 1, 2, sensors=False)
    base = track.checkpoint_s[23]
    world.place_kart(0, 0, base + 2.0 + 1.0, 1.25, speed=5.0)  # nose-to-body gap of 1.0 m < s1 = 1.5 m
    world.place_kart(0, 1, base, 1.25, speed=5.0)
    world.step(np.tile([0.0, 0.0], (1, 2, 1)))
    assert world.istate[0, 1, st.I_BUFFER_VIOLATIONS] == 1
    assert world.istate[0, 0, st.I_BUFFER_VIOLATIONS] == 0
    # side by side 1.5 m apart: bodies 0.6 m apart > s0 = 0.5 m, nobody violates
    world.place_kart(0, 0, base, 1.25, speed=5.0)
    world.place_kart(0, 1, base, -0.25, speed=5.0)
    world.step(np.tile([0.0, 0.0], (1, 2, 1)))
    assert world.istate[0, :, st.I_BUFFER_VIOLATIONS].tolist() == [0, 0]


def test_rays_hand_checked_on_a_straight() -> None:
    track = get_track("oval")
    world = World(track, 1, 2)  # karts side by side in lanes 2 (+1.25) and 3 (-1.25) on a straight
    dist, hit = world.ray_dist[0, 0], world.ray_hit[0, 0]
    # ray order: 0, +30 (right), +45, +60, +90, -30 (left), -45, -60, -90
    right_wall, left_wall = 5.0 + 1.25, 5.0 - 1.25
    assert dist[0] == pytest.approx(20.0) and hit[0] == st.HIT_NONE
    for i, angle in ((1, 30), (2, 45), (3, 60)):
        assert dist[i] == pytest.approx(right_wall / np.sin(np.deg2rad(angle)), abs=0.02)
        assert hit[i] == st.HIT_WALL
    for i, angle in ((5, 30), (6, 45), (7, 60), (8, 90)):
        assert dist[i] == pytest.approx(left_wall / np.sin(np.deg2rad(angle)), abs=0.02)
        assert hit[i] == st.HIT_WALL
    # +90 sees the other kart: centres 2.5 m apart, minus its radius, minus nothing (origin on the axis)
    assert dist[4] == pytest.approx(2.5 - 0.45, abs=0.02) and hit[4] == st.HIT_KART


def test_events_report_checkpoints() -> None:
    track = get_track("oval")
    world = World(track, 1, 1, sensors=False)
    seen = 0
    while world.istate[0, 0, st.I_CP_PASSED] < 3:
        world.step(np.array([[[0.0, 1.0]]]))
        seen += int(world.events[0, 0] & st.EV_CHECKPOINT != 0)
    assert seen == 3


def test_sliding_along_a_wall_costs_coulomb_friction() -> None:
    track = get_track("oval")
    world = World(track, 1, 1, sensors=False)
    angle = np.deg2rad(20.0)
    # on the first straight, heading 20 deg into the left wall, coasting
    world.place_kart(0, 0, 8.0, 3.0, heading_offset=angle, speed=10.0)
    previous = 10.0
    for _ in range(100):
        world.step(np.zeros((1, 1, 2)))
        if world.istate[0, 0, st.I_WALL_CONTACT]:
            break
        previous = float(world.speeds[0, 0])
    else:
        raise AssertionError("never reached the wall")
    approach = previous - 2.0 * 0.02  # this step's coasting
    mu = world.params.kart.wall_friction
    assert world.speeds[0, 0] == pytest.approx(approach * (np.cos(angle) - mu * np.sin(angle)), rel=1e-6)
    # the wall turns the body toward its tangent (the straight heads +y) no faster than wall_yaw_rate: no snap
    turn = world.params.kart.wall_yaw_rate * 0.02
    assert world.headings[0, 0] == pytest.approx(np.pi / 2 + angle - turn, abs=1e-9)
    # within half a second it runs parallel to the wall, still sliding, and it was one hit
    world.step(np.zeros((1, 1, 2)), n_steps=25)
    assert world.headings[0, 0] == pytest.approx(np.pi / 2, abs=1e-2)
    assert world.speeds[0, 0] > 0.0
    assert world.istate[0, 0, st.I_WALL_HITS] == 1
