"""The discrete game's 1-D time model against hand-computed cases."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as hs

from controllers.tactical.motion import INFEASIBLE, segment_time


def test_pure_acceleration() -> None:
    # 0 -> 10 m/s at 4 m/s^2 takes 2.5 s over exactly 12.5 m
    assert segment_time(12.5, 0.0, 10.0, 4.0, 6.0, 15.0) == pytest.approx(2.5)


def test_accelerate_cruise_brake() -> None:
    # 6 -> 15 (2.25 s, 23.625 m), cruise, 15 -> 9 (1 s, 12 m) over 100 m: cruise 64.375 m = 4.2917 s
    t = segment_time(100.0, 6.0, 9.0, 4.0, 6.0, 15.0)
    assert t == pytest.approx(2.25 + 64.375 / 15.0 + 1.0)


def test_triangle_profile() -> None:
    # 0 -> 0 over 20 m with a = 4, b = 6: peak^2 = 2*20*4*6/10 = 96, t = peak/4 + peak/6
    peak = math.sqrt(96.0)
    assert segment_time(20.0, 0.0, 0.0, 4.0, 6.0, 15.0) == pytest.approx(peak / 4 + peak / 6)


def test_entering_above_the_ceiling_brakes_first() -> None:
    # 15 -> ceiling 9 (1 s, 12 m), cruise 9 for 18 m (2 s), arrive at 9
    assert segment_time(30.0, 15.0, 9.0, 4.0, 6.0, 9.0) == pytest.approx(3.0)


def test_infeasible_cases() -> None:
    assert segment_time(10.0, 0.0, 15.0, 4.0, 6.0, 15.0) == INFEASIBLE  # needs 28.1 m to reach 15
    assert segment_time(10.0, 15.0, 0.0, 4.0, 6.0, 15.0) == INFEASIBLE  # needs 18.75 m to stop
    assert segment_time(10.0, 6.0, 12.0, 4.0, 6.0, 10.0) == INFEASIBLE  # arrival above the ceiling
    assert segment_time(5.0, 15.0, 6.0, 4.0, 6.0, 8.0) == INFEASIBLE  # cannot brake to the ceiling in time


@given(
    distance=hs.floats(1.0, 60.0),
    v0=hs.floats(0.0, 15.0),
    v1=hs.floats(0.0, 15.0),
    v_max=hs.floats(4.0, 15.0),
)
def test_time_is_at_least_distance_over_the_highest_speed(distance: float, v0: float, v1: float, v_max: float) -> None:
    t = segment_time(distance, v0, v1, 4.0, 6.0, v_max)
    if t != INFEASIBLE:
        assert t >= distance / max(v_max, v0) - 1e-9
        # never faster than covering the distance at the ceiling the whole way
        assert v1 <= v_max + 1e-9
