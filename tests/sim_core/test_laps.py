"""Lap times (sim_core.laps.LapTimer) from the state a step leaves, and the start lanes of the grid."""

from __future__ import annotations

import pytest

from sim_core import state as st
from sim_core.laps import LapTimer
from sim_core.track_io import get_track
from sim_core.world import World, grid_lanes


def test_a_lap_ends_at_the_crossing_that_completes_it() -> None:
    track = get_track("oval")
    n = track.n_checkpoints
    world = World(track, 1, 2, laps=3)
    world.reset()
    timer = LapTimer(2, n)
    # (checkpoints passed by kart 0, time of its last crossing) after successive steps
    for passed, crossing in ((n - 1, 30.1), (n, 31.25), (n + 1, 32.0), (2 * n, 60.75), (2 * n, 60.75)):
        world.istate[0, 0, st.I_CP_PASSED] = passed
        world.fstate[0, 0, st.F_CROSS_TIME] = crossing
        timer.observe(world)
    assert timer.lap_times(0) == pytest.approx((31.25, 29.5))
    assert timer.lap_times(1) == ()  # still on the grid
    assert timer.all_lap_times() == (timer.lap_times(0), ())


def test_grid_lanes_are_the_lanes_reset_uses() -> None:
    assert grid_lanes(2) == (2, 3)
    assert grid_lanes(6) == (2, 3, 1, 4, 2, 3)
    assert grid_lanes(2, (4, 1)) == (4, 1)
    track = get_track("oval")
    world = World(track, 1, 3)
    world.reset()
    assert tuple(int(lane) for lane in world.istate[0, :, st.I_LANE_NOW]) == grid_lanes(3)
