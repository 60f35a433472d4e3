"""Stall recovery: when it takes over, for how long, which way it steers, and that only it reverses."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from controllers.base import Action
from controllers.rl.recovery import StallRecovery

DT = 0.04  # the RL tracker's decision period


FACING_THE_WALL = 1.5  # [rad] heading error beyond the drive-off cone: the manoeuvre reverses


def drive(
    recovery: StallRecovery, speeds: list[float], heading_error: float = FACING_THE_WALL
) -> list[tuple[float, float] | None]:
    """The override at each decision for a kart at ``speeds`` (one per decision)."""
    out = []
    for i, v in enumerate(speeds):
        action = recovery.override(i * DT, v, heading_error)
        out.append(None if action is None else (action.steer, action.throttle))
    return out


def test_a_moving_kart_is_never_overridden() -> None:
    assert drive(StallRecovery(), [3.0] * 200) == [None] * 200


def test_a_start_from_rest_is_not_a_stall() -> None:
    # standing for 0.44 s at the start (11 decisions), then moving: no manoeuvre
    recovery = StallRecovery()
    assert drive(recovery, [0.0] * 11 + [2.0] * 50) == [None] * 61
    assert recovery.manoeuvres == 0


def test_a_kart_stalled_facing_the_wall_reverses_for_a_second_after_half_a_second() -> None:
    recovery = StallRecovery()
    out = drive(recovery, [0.0] * 120, heading_error=FACING_THE_WALL)
    first = next(i for i, a in enumerate(out) if a is not None)
    assert math.isclose(first * DT, 0.5, abs_tol=DT + 1e-9)
    reversing = [a for a in out[first:] if a is not None]
    # 1 s of full reverse (25 decisions), then the policy drives again before the next stall
    assert out[first : first + 25] == [(-1.0, -1.0)] * 25
    assert out[first + 25] is None
    assert all(a == (-1.0, -1.0) for a in reversing)
    assert recovery.manoeuvres >= 2  # still stalled after backing off: it tries again


def test_it_steers_so_that_the_reversing_nose_turns_toward_the_track() -> None:
    # the track turns left of the nose (positive error): reversing with the wheel to the right swings the nose left
    left = drive(StallRecovery(), [0.0] * 40, heading_error=FACING_THE_WALL)
    right = drive(StallRecovery(), [0.0] * 40, heading_error=-FACING_THE_WALL)
    assert {a[0] for a in left if a} == {-1.0}
    assert {a[0] for a in right if a} == {1.0}


def test_reset_forgets_a_manoeuvre() -> None:
    recovery = StallRecovery()
    drive(recovery, [0.0] * 30)
    recovery.reset()
    assert recovery.manoeuvres == 0 and recovery.override(0.0, 5.0, 0.0) is None


def test_a_kart_stalled_along_the_track_drives_off_toward_its_direction() -> None:
    # stopped beside the wall but pointing down the track (measured at the exits of complex's hairpins, where the
    # policy coasts at a standstill): full throttle, steering toward the track's direction, for a second
    left = drive(StallRecovery(), [0.0] * 40, heading_error=0.2)
    right = drive(StallRecovery(), [0.0] * 40, heading_error=-0.2)
    assert [a for a in left if a] == [(0.4, 1.0)] * 25
    assert [a for a in right if a] == [(-0.4, 1.0)] * 25


@given(
    steer=st.floats(-1.0, 1.0),
    throttle=st.floats(-1.0, 1.0),
    speed=st.floats(-5.0, 15.0),
)
def test_only_the_manoeuvre_reverses(steer: float, throttle: float, speed: float) -> None:
    """A policy's brake at a standstill or rolling backwards is released (it would reverse); every other input
    passes unchanged."""
    recovery = StallRecovery()
    out = recovery.forward_only(Action(steer, throttle), speed)
    assert out.steer == steer
    if throttle < 0.0 and speed <= recovery.standstill_speed:
        assert out.throttle == 0.0
    else:
        assert out.throttle == throttle
