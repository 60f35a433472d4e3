"""Where a kart finishes: at the line on its last lap (the paper's), or, racing a distance, after the race's laps
from its own grid slot (``World.reset(finish="equal_distance")``)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hst

from sim_core import state as st
from sim_core.conditions import ConditionSet
from sim_core.laps import LapTimer
from sim_core.params import DT
from sim_core.track_io import get_track
from sim_core.world import MAX_KARTS, World


@pytest.mark.parametrize("grid", ["side_by_side", "staggered"])
@pytest.mark.parametrize("track_name", ["oval", "complex"])
def test_every_slot_of_a_two_row_grid_is_the_same_distance_from_its_flag(grid: str, track_name: str) -> None:
    track = get_track(track_name)
    drawn = ConditionSet("fair", grid=grid, stagger=1.5, finish="equal_distance").draw(0, MAX_KARTS)  # type: ignore[arg-type]
    world = World(track, 1, MAX_KARTS, laps=2)
    world.reset(start_offsets=drawn.start_offsets, finish=drawn.finish)
    start = world.total_progress()[0]
    assert np.ptp(start) >= 4.0, "the grid has no second row: the check would pass on nothing"
    np.testing.assert_allclose(world.finish_at[0] - start, 2 * track.length, rtol=0, atol=1e-9)
    world.reset(start_offsets=drawn.start_offsets)  # at the line: the front row is nearer the flag
    assert np.isnan(world.finish_at[0]).all()


def _rolling_kart(finish: str, s: float, speed: float, laps: int = 1) -> World:
    """A one-kart race, the kart at progress ``s`` of its last lap (behind the line: before it) in lane 2,
    rolling at ``speed`` [m/s] on the oval's start straight; racing a distance, its slot is 3 m past the line."""
    world = World(get_track("oval"), 1, 1, laps=laps)
    world.reset(finish=finish)  # type: ignore[arg-type]
    d = float(world.track.lane_offsets(0)[1])
    world.place_kart(0, 0, s=s, d=d, speed=speed, lap=laps)
    return world


@settings(max_examples=25, deadline=None)
@given(before=hst.floats(0.05, 0.5), speed=hst.floats(5.0, 15.0))
def test_racing_a_distance_a_kart_finishes_at_its_slot_at_the_interpolated_time(before: float, speed: float) -> None:
    """The kart stands ``before`` m short of its finish 3 m past the line, rolling at ``speed``: it finishes in
    the step that carries it past, at the time it got there (the distance over its speed, to the step's
    drag); crossing the line itself on its last lap did not finish it."""
    world = _rolling_kart("equal_distance", 3.0 - before, speed)
    assert world.finish_at[0, 0] == pytest.approx(3.0 + world.track.length)
    steps = 0
    while not world.istate[0, 0, st.I_FINISHED]:
        world.step(np.array([[[0.0, 0.0]]]))
        steps += 1
        assert steps < 50
    assert world.fstate[0, 0, st.F_FINISH_TIME] == pytest.approx(before / speed, abs=0.2 * DT)


def test_at_the_line_the_last_crossing_finishes_and_racing_a_distance_it_does_not() -> None:
    for finish, finished in (("line", True), ("equal_distance", False)):
        world = _rolling_kart(finish, -0.5, 10.0)
        world.step(np.array([[[0.0, 0.0]]]), n_steps=5)  # 1 m: over the line, 2.5 m short of the slot
        assert bool(world.istate[0, 0, st.I_FINISHED]) is finished, finish


def test_a_second_row_kart_finishes_short_of_the_line_with_its_laps_counted() -> None:
    """A kart whose slot is 5 m behind the line finishes 5 m before it on its last lap: all laps completed in its
    result, its lap times adding up to its finish time."""
    world = World(get_track("oval"), 1, 5, laps=1)
    world.reset(finish="equal_distance")  # kart 4 stands in the second row, 1 m behind the line
    timer = LapTimer(5, world.track.n_checkpoints)
    slot = world.total_progress()[0, 4]
    assert slot == pytest.approx(-1.0)
    world.place_kart(0, 4, s=world.track.length - 1.5, d=float(world.track.lane_offsets(0)[1]), speed=10.0)
    for _ in range(10):
        world.step()
        timer.observe(world)
    result = world.result(0).karts[4]
    assert result.finished and result.laps_completed == 1
    assert result.finish_time == pytest.approx(0.5 / 10.0, abs=0.2 * DT)
    assert sum(timer.lap_times(4)) == pytest.approx(result.finish_time)
    assert world.result(0).winner == 4
