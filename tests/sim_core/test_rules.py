"""The lane-change rule (eqs. 9-10) as a function and through the referee, tried with random lane sequences."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as hs

from sim_core import state as st
from sim_core.rules import front_touches, lane_change_update, required_buffer
from sim_core.track_io import get_track
from sim_core.world import World


def reference_lane_counter(lanes: list[int], straight: list[bool], limit: int) -> tuple[list[int], list[bool]]:
    """Counter and illegality after each crossing, written from eq. (10) with the original's semantics.

    ``lanes[c]`` is the lane at crossing checkpoint c (c = 0 is the start), ``straight[c]`` whether the road
    from checkpoint c to c + 1 is straight. The counter after crossing c is the number of lanes crossed since
    the last crossing at which the road type changed (that crossing resets it to 0).
    """
    counters, illegal = [0], [False]
    run_start = 0  # the counter accumulates the lane changes of crossings after this one
    for c in range(1, len(lanes)):
        crossed = abs(lanes[c] - lanes[c - 1])
        before = sum(abs(lanes[q] - lanes[q - 1]) for q in range(run_start + 1, c))
        illegal.append(straight[c - 1] and crossed > 0 and before + crossed > limit)
        if straight[c - 1] != straight[c]:
            run_start = c
            counters.append(0)
        else:
            counters.append(before + crossed)
    return counters, illegal


lane_sequences = hs.lists(hs.integers(1, 4), min_size=2, max_size=60)


@given(lanes=lane_sequences, flags=hs.lists(hs.booleans(), min_size=60, max_size=60), limit=hs.integers(0, 5))
def test_counter_matches_the_reference(lanes: list[int], flags: list[bool], limit: int) -> None:
    straight = flags[: len(lanes)]
    expected_counts, expected_illegal = reference_lane_counter(lanes, [*straight, straight[-1]], limit)
    count = 0
    for c in range(1, len(lanes)):
        next_straight = straight[c] if c < len(straight) else straight[-1]
        count, illegal = lane_change_update(count, lanes[c - 1], lanes[c], straight[c - 1], next_straight, limit)
        assert count == expected_counts[c]
        assert illegal == expected_illegal[c]


@given(lanes=lane_sequences, limit=hs.integers(0, 5))
def test_lane_changes_on_curves_are_never_illegal(lanes: list[int], limit: int) -> None:
    count = 0
    for c in range(1, len(lanes)):
        count, illegal = lane_change_update(count, lanes[c - 1], lanes[c], False, c % 3 == 0, limit)
        assert not illegal


def test_crossing_without_a_change_is_never_illegal_even_above_the_limit() -> None:
    count, illegal = lane_change_update(9, 2, 2, True, True, 3)
    assert (count, illegal) == (9, False)


def test_hand_checked_sequence_on_a_straight() -> None:
    # L = 3: 1 -> 4 crosses 3 lanes (legal, counter 3); 4 -> 3 takes it to 4 > 3 (illegal)
    count, illegal = lane_change_update(0, 1, 4, True, True, 3)
    assert (count, illegal) == (3, False)
    count, illegal = lane_change_update(count, 4, 3, True, True, 3)
    assert (count, illegal) == (4, True)
    # leaving the straight into a curve resets the counter after judging the last change
    count, illegal = lane_change_update(count, 3, 1, True, False, 3)
    assert (count, illegal) == (0, True)


def test_fault_and_buffer_helpers() -> None:
    assert front_touches(1.0, 1.0, 0.5)  # nose into the other's body, straight ahead
    assert not front_touches(0.0, 1.0, 0.5)  # contact at the rear end
    assert not front_touches(1.0, 0.0, 0.5)  # side by side: the other is beside, not ahead
    assert required_buffer(True, 0.5, 1.5) == 1.5
    assert required_buffer(False, 0.5, 1.5) == 0.5


def cross_checkpoints(world: World, lanes: list[int]) -> None:
    """Put kart 0 just before each next checkpoint in the given lane and step it over the line."""
    track = world.track
    n = track.n_checkpoints
    for lane in lanes:
        c = (int(world.istate[0, 0, st.I_CP_PASSED]) + 1) % n
        s = (track.checkpoint_s[c] - 0.1) % track.length
        point, tangent = track.point_at(s)
        d = track.lane_offsets(c)[lane - 1]
        xy = point + np.array([-tangent[1], tangent[0]]) * d
        f = world.fstate[0, 0]
        f[st.F_X], f[st.F_Y] = xy
        f[st.F_HEADING] = np.arctan2(tangent[1], tangent[0])
        f[st.F_SPEED] = 10.0
        f[st.F_S], f[st.F_D] = s, d
        world.istate[0, 0, st.I_CENTRE_IDX] = int(np.searchsorted(track.centre_s, s)) % len(track.centre_s)
        world.step(np.zeros((1, 1, 2)))


@settings(max_examples=30, deadline=None)
@given(lanes=hs.lists(hs.integers(1, 4), min_size=1, max_size=50), track_name=hs.sampled_from(["oval", "complex"]))
def test_referee_counts_lane_changes_like_the_reference(lanes: list[int], track_name: str) -> None:
    track = get_track(track_name)
    world = World(track, 1, 1, sensors=False)
    world.reset(start_lanes=[2])
    cross_checkpoints(world, lanes)
    n = track.n_checkpoints
    sequence = [2, *lanes]
    straight = [track.section_is_straight(c) for c in range(len(sequence) + 1)]
    counts, illegal = reference_lane_counter(sequence, straight, track.lane_change_limit)
    assert int(world.istate[0, 0, st.I_CP_PASSED]) == len(lanes)
    assert int(world.istate[0, 0, st.I_LANE]) == lanes[-1]
    assert int(world.istate[0, 0, st.I_LANE_COUNT]) == counts[-1]
    assert int(world.istate[0, 0, st.I_ILLEGAL]) == sum(illegal)
    # and never on a curve
    curve_changes = [c for c in range(1, len(sequence)) if not straight[(c - 1) % n] and illegal[c]]
    assert curve_changes == []
