"""The pace handicap: a kart at pace r is the reference kart with speeds times r and accelerations times r², so it
drives the same line 1/r times slower; at pace 1 nothing changes, bit for bit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st_

from controllers.race import RaceSpec, run_race
from sim_core import state
from sim_core.params import ORIGINAL_KART, PAPER_KART, SimParams
from sim_core.track_io import get_track
from sim_core.world import World


def test_paced_parameters_scale_speeds_by_r_and_accelerations_by_r_squared() -> None:
    kart = ORIGINAL_KART.paced(0.9)
    assert kart.top_speed == pytest.approx(13.5) and kart.reverse_speed == pytest.approx(4.5)
    assert kart.acceleration == pytest.approx(12.0 * 0.81) and kart.braking == pytest.approx(10.0 * 0.81)
    assert kart.coasting_drag == pytest.approx(2.0 * 0.81) and kart.reverse_acceleration == pytest.approx(5.0 * 0.81)
    assert kart.lateral_g_fresh == pytest.approx(2.0 * 0.81) and kart.lateral_g_worn == pytest.approx(0.5 * 0.81)
    assert kart.wall_yaw_rate == pytest.approx(3.0 * 0.9)
    # the same geometry, body, wear per radian and pedal curve
    unchanged = ("wheelbase", "max_steer_angle", "body_radius", "body_half_length", "wear_yaw_scale", "low_speed_gain")
    assert all(getattr(kart, f) == getattr(ORIGINAL_KART, f) for f in unchanged)
    assert kart.name == "original@0.9" and PAPER_KART.paced(1.0) is PAPER_KART
    for bad in (0.3, 1.01, 0.0):
        with pytest.raises(ValueError, match="pace must be in"):
            PAPER_KART.paced(bad)


def _straight_run(pace: float, throttle: float, steps: int, speed: float = 0.0) -> np.ndarray:
    """(steps,) speeds of kart 1 of a 2-kart world (no drag) driven straight from the oval's start line at
    ``speed``, kart 0 at pace 1 beside it."""
    world = World(get_track("oval"), 1, 2, SimParams(kart=replace(PAPER_KART, coasting_drag=0.0)))
    world.reset(start_lanes=(1, 4), paces=(1.0, pace))
    world.place_kart(0, 1, s=1.0, d=float(world.track.lane_offsets(0)[3]), speed=speed)
    speeds = []
    for _ in range(steps):
        world.step(np.array([[[0.0, throttle], [0.0, throttle]]]))
        speeds.append(world.fstate[0, 1, state.F_SPEED])
    return np.array(speeds)


@settings(max_examples=15, deadline=None)
@given(pace=st_.floats(0.5, 1.0), throttle=st_.floats(0.1, 1.0))
def test_a_paced_kart_accelerates_at_r_squared_and_tops_out_at_r(pace: float, throttle: float) -> None:
    """Without drag, in a straight line: from rest v(t) = throttle x r² a t; from near its top speed, capped at
    r x the reference's top speed."""
    speeds = _straight_run(pace, throttle, 100)
    expected = throttle * pace**2 * PAPER_KART.acceleration * 0.02 * np.arange(1, 101)
    np.testing.assert_allclose(speeds, expected, atol=1e-9)
    topped = _straight_run(pace, 1.0, 30, speed=pace * 15.0 - 0.5)
    assert topped[-1] == pytest.approx(pace * 15.0, abs=1e-12) and topped.max() <= pace * 15.0 + 1e-12


def test_at_pace_1_the_world_steps_bit_for_bit_as_without_a_pace() -> None:
    rng = np.random.default_rng(5)
    plain, paced = (World(get_track("complex"), 2, 2) for _ in range(2))
    plain.reset()
    paced.reset(paces=(1.0, 1.0))
    paced.set_pace(1, 0, 0.8)
    paced.set_pace(1, 0, 1.0)  # and back
    for _ in range(400):
        actions = rng.uniform(-1.0, 1.0, (2, 2, 2))
        plain.step(actions)
        paced.step(actions)
    assert np.array_equal(plain.fstate, paced.fstate) and np.array_equal(plain.istate, paced.istate)


@pytest.mark.parametrize(("agent", "tolerance"), [("fixed-lqng", 0.005), ("mcts-lqng", 0.005), ("fixed-rl", 0.015)])
def test_a_solo_lap_at_pace_r_takes_1_over_r_of_the_reference_lap(agent: str, tolerance: float) -> None:
    """One lap of the oval from a standing start: the LQNG agents within 0.5% of 1/r, an RL agent (deciding at
    25 Hz of race time, not of its own) within 1.5%."""

    def lap(pace: float) -> float:
        name = agent if pace == 1.0 else f"{agent}@{pace}"
        finish = run_race(RaceSpec(track="oval", controllers=(name,), laps=1, start_lanes=(2,))).result.karts[0]
        assert finish.finish_time is not None and finish.wall_hits == 0
        return finish.finish_time

    reference = lap(1.0)
    assert lap(0.9) * 0.9 / reference == pytest.approx(1.0, abs=tolerance)
