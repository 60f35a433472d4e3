"""Overtakes counted by the referee: a pass counts once held for 2 s (or to the finish); a place lost back
sooner is no pass; the starting order is not a pass."""

from __future__ import annotations

import numpy as np

from sim_core import state as st
from sim_core.kart import throttle_for_acceleration
from sim_core.track_io import get_track
from sim_core.world import World


def side_lanes(fast: float, slow: float, gap: float) -> World:
    """Kart 0 in lane 1 ``gap`` m behind kart 1 in lane 3, at ``fast`` and ``slow`` m/s, on the oval's long
    straight run."""
    track = get_track("oval")
    world = World(track, 1, 2, sensors=False)
    base = float(track.checkpoint_s[10]) + 1.0
    world.place_kart(0, 0, base, float(track.lane_offsets(10)[0]), speed=fast)
    world.place_kart(0, 1, base + gap, float(track.lane_offsets(10)[2]), speed=slow)
    return world


def hold(world: World, speeds: tuple[float, float], steps: int) -> None:
    """Drive both karts straight ahead, each commanded toward its speed."""
    for _ in range(steps):
        actions = np.zeros((1, 2, 2))
        for k in range(2):
            v = float(world.speeds[0, k])
            actions[0, k, 1] = throttle_for_acceleration(world.kart_vector, v, 4.0 * (speeds[k] - v))
        world.step(actions)


def test_an_overtake_held_for_two_seconds_is_a_pass() -> None:
    world = side_lanes(12.0, 8.0, 4.0)
    hold(world, (12.0, 8.0), 60)  # gains 4 m/s: past after about a second
    assert world.istate[0, :, st.I_PASSES].tolist() == [0, 0]  # ahead, not yet held
    hold(world, (12.0, 8.0), 110)  # 2 s on, give or take the 0.1 s between checks of the running order
    assert world.istate[0, :, st.I_PASSES].tolist() == [1, 0]
    assert world.result(0).karts[0].passes == 1
    assert [k.passes_of for k in world.result(0).karts] == [(0, 1), (0, 0)]  # kart 0 passed kart 1


def test_a_place_lost_back_within_two_seconds_is_no_pass() -> None:
    world = side_lanes(12.0, 8.0, 4.0)
    hold(world, (12.0, 8.0), 60)
    hold(world, (3.0, 10.0), 60)  # kart 0 brakes: kart 1 is back ahead in under 2 s
    assert world.istate[0, :, st.I_PASSES].tolist() == [0, 0]
    hold(world, (3.0, 10.0), 150)  # kart 1 took its place back and held it: that one is a pass
    assert world.istate[0, :, st.I_PASSES].tolist() == [0, 1]
    assert [k.passes_of for k in world.result(0).karts] == [(0, 0), (1, 0)]  # kart 1 passed kart 0


def test_the_starting_order_is_not_a_pass() -> None:
    world = World(get_track("oval"), 1, 2, sensors=False)
    hold(world, (10.0, 6.0), 300)  # side by side on the grid: kart 0 simply pulls away
    assert world.istate[0, :, st.I_PASSES].tolist() == [0, 0]


def test_a_pair_count_stops_at_its_fields_largest_value_and_leaves_the_others_alone() -> None:
    from sim_core.referee import add_pair_count, pair_count

    flags = st.PAIR_CONTACT | st.PAIR_ORDER_KNOWN
    for _ in range(600):
        flags = add_pair_count(flags, st.PAIR_PASS_I_SHIFT, st.PAIR_PASS_BITS)
    flags = add_pair_count(flags, st.PAIR_CONTACT_SHIFT, st.PAIR_CONTACT_BITS)
    words = np.array([flags])
    assert pair_count(words, st.PAIR_PASS_I_SHIFT, st.PAIR_PASS_BITS).tolist() == [2**st.PAIR_PASS_BITS - 1]
    assert pair_count(words, st.PAIR_PASS_J_SHIFT, st.PAIR_PASS_BITS).tolist() == [0]
    assert pair_count(words, st.PAIR_CONTACT_SHIFT, st.PAIR_CONTACT_BITS).tolist() == [1]
    assert flags & 0xFF == st.PAIR_CONTACT | st.PAIR_ORDER_KNOWN and flags > 0
