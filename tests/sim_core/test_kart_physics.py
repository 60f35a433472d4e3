"""Kart dynamics against hand-computed figures for both presets."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from sim_core.kart import kart_step
from sim_core.params import DT, GRAVITY, ORIGINAL_KART, PAPER_KART, KartParams


def drive_straight(params: KartParams, speed: float, throttle: float, until, max_steps: int = 100_000):
    """Step one kart straight ahead until ``until(speed)``; returns (steps, distance, speed)."""
    p = params.as_array()
    x = y = heading = slip = 0.0
    acc_yaw = 0.0
    for step in range(max_steps):
        if until(speed):
            return step, x, speed
        x, y, heading, speed, slip, _, acc_yaw = kart_step(p, x, y, heading, speed, slip, acc_yaw, 0.0, throttle, DT)
    raise AssertionError("condition never reached")


@pytest.mark.parametrize("params", [PAPER_KART, ORIGINAL_KART], ids=lambda p: p.name)
def test_full_throttle_reaches_top_speed_in_hand_computed_time(params: KartParams) -> None:
    steps, distance, speed = drive_straight(params, 0.0, 1.0, lambda v: v >= params.top_speed - 1e-9)
    if params.low_speed_gain == 1.0:
        # constant 4 m/s^2: 15 / 4 = 3.75 s, 15^2 / (2 * 4) = 28.125 m
        expected_time = params.top_speed / params.acceleration
        expected_distance = params.top_speed**2 / (2 * params.acceleration)
    else:
        # dv/dt = a (g + (1 - g) u^2), u = v / V: t = V/(a g) * atanh(k u)/k with k = sqrt((g - 1) / g)
        g, a, top = params.low_speed_gain, params.acceleration, params.top_speed
        k = math.sqrt((g - 1) / g)
        expected_time = top / (a * g) * math.atanh(k) / k
        # distance = int v dt = int v / (a(g + (1-g)u^2)) dv = V^2/(a) * int u/(g - (g-1)u^2) du
        expected_distance = top**2 / a * (-math.log(1 - (g - 1) / g) / (2 * (g - 1)))
    assert steps * DT == pytest.approx(expected_time, abs=2 * DT)
    assert distance == pytest.approx(expected_distance, rel=0.02)
    assert speed == pytest.approx(params.top_speed)


def test_paper_preset_figures() -> None:
    assert PAPER_KART.top_speed == 15.0
    assert PAPER_KART.acceleration == 4.0
    assert PAPER_KART.braking == 6.0
    assert PAPER_KART.lateral_g_fresh == 1.5
    assert ORIGINAL_KART.acceleration == 12.0 and ORIGINAL_KART.braking == 10.0
    assert ORIGINAL_KART.lateral_g_fresh == 2.0 and ORIGINAL_KART.lateral_g_worn == 0.5


@pytest.mark.parametrize("params", [PAPER_KART, ORIGINAL_KART], ids=lambda p: p.name)
def test_full_brake_from_top_speed_stops_in_hand_computed_distance(params: KartParams) -> None:
    steps, distance, _ = drive_straight(params, params.top_speed, -1.0, lambda v: v <= 0.0)
    if params.low_speed_gain == 1.0:
        # 15 / 6 = 2.5 s and 15^2 / (2 * 6) = 18.75 m
        assert steps * DT == pytest.approx(params.top_speed / params.braking, abs=2 * DT)
        assert distance == pytest.approx(params.top_speed**2 / (2 * params.braking), rel=0.02)
    else:
        g, b, top = params.low_speed_gain, params.braking, params.top_speed
        k = math.sqrt((g - 1) / g)
        expected_time = top / (b * g) * math.atanh(k) / k
        assert steps * DT == pytest.approx(expected_time, abs=2 * DT)


def test_coasting_decelerates_at_the_drag_rate() -> None:
    steps, _, _ = drive_straight(PAPER_KART, 10.0, 0.0, lambda v: v <= 0.0)
    assert steps * DT == pytest.approx(10.0 / PAPER_KART.coasting_drag, abs=2 * DT)


def test_held_brake_from_standstill_reverses_up_to_reverse_speed() -> None:
    steps, distance, speed = drive_straight(PAPER_KART, 0.0, -1.0, lambda v: v <= -PAPER_KART.reverse_speed + 1e-9)
    assert speed == pytest.approx(-PAPER_KART.reverse_speed)
    assert steps * DT == pytest.approx(PAPER_KART.reverse_speed / PAPER_KART.reverse_acceleration, abs=2 * DT)
    assert distance < 0


def circle_speed(params: KartParams, steer: float, wear: float, seconds: float = 30.0) -> tuple[float, float]:
    """Hold full throttle and a fixed steer; return (final speed, measured path radius)."""
    p = params.as_array()
    acc_yaw = params.yaw_for_wear(wear)
    x = y = heading = slip = 0.0
    speed = 0.0
    for _ in range(int(seconds / DT)):
        x, y, heading, speed, slip, yaw_rate, _ = kart_step(p, x, y, heading, speed, slip, acc_yaw, steer, 1.0, DT)
        # wear is frozen to test the steady state at that wear level
    return speed, speed / abs(yaw_rate)


@pytest.mark.parametrize("wear", [0.0, 0.25, 0.6])
def test_steady_cornering_speed_is_at_the_lateral_limit(wear: float) -> None:
    params = PAPER_KART
    steer = 0.3
    delta = steer * params.max_steer_angle
    tan_beta = 0.5 * math.tan(delta)
    radius = params.wheelbase / (math.cos(math.atan(tan_beta)) * math.tan(delta))
    a_lat = (params.lateral_g_worn + (1 - wear) * (params.lateral_g_fresh - params.lateral_g_worn)) * GRAVITY
    expected = min(math.sqrt(a_lat * radius), params.top_speed)
    speed, measured_radius = circle_speed(params, steer, wear)
    assert expected < params.top_speed  # the limit binds for this steer
    assert speed == pytest.approx(expected, rel=1e-6)
    assert measured_radius == pytest.approx(radius, rel=1e-6)
    assert speed**2 / measured_radius == pytest.approx(a_lat, rel=1e-6)


def test_wear_lowers_the_cornering_speed() -> None:
    speeds = [circle_speed(PAPER_KART, 0.3, w)[0] for w in (0.0, 0.3, 0.6, 0.9)]
    assert all(a > b for a, b in itertools.pairwise(speeds))
    # cornering speed scales with sqrt(grip): 1.5 g fresh vs 0.5 + 0.1 * 1.0 = 0.6 g at wear 0.9
    assert speeds[0] / speeds[-1] == pytest.approx(math.sqrt(1.5 / 0.6), rel=1e-6)


def test_wear_grows_exponentially_with_accumulated_yaw() -> None:
    p = PAPER_KART.as_array()
    x = y = heading = slip = 0.0
    speed, acc_yaw = 8.0, 0.0
    for _ in range(int(60 / DT)):
        x, y, heading, speed, slip, _yaw_rate, acc_yaw = kart_step(p, x, y, heading, speed, slip, acc_yaw, 0.5, 0.3, DT)
    # accumulated yaw is the integral of |yaw rate| (about 2 pi per full circle driven)
    assert acc_yaw > 2 * math.pi
    wear = float(PAPER_KART.wear_from_yaw(acc_yaw))
    assert wear == pytest.approx(min(1.0, 4 / 3 * (1 - math.exp(-acc_yaw / 200.0))))
    assert PAPER_KART.yaw_for_wear(0.25) == pytest.approx(-200 * math.log(1 - 0.25 * 3 / 4))
    assert float(PAPER_KART.wear_from_yaw(PAPER_KART.yaw_for_wear(0.25))) == pytest.approx(0.25)


def test_nan_and_out_of_range_inputs_are_clamped() -> None:
    p = PAPER_KART.as_array()
    base = kart_step(p, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 1.0, 1.0, DT)
    clamped = kart_step(p, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 7.0, 3.0, DT)
    assert np.allclose(base, clamped)
    nan_in = kart_step(p, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, float("nan"), float("nan"), DT)
    coast = kart_step(p, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, DT)
    assert np.allclose(nan_in, coast)


def test_positive_steer_turns_left() -> None:
    p = PAPER_KART.as_array()
    *_, yaw_rate, _ = kart_step(p, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.5, 0.0, DT)
    assert yaw_rate > 0


@pytest.mark.parametrize("params", [PAPER_KART, ORIGINAL_KART], ids=lambda p: p.name)
def test_compiled_wear_and_grip_model_equals_the_parameter_methods(params: KartParams) -> None:
    """One tyre-wear / grip model: the kernels' (also the planner's game's) and KartParams' vectorised twin."""
    from sim_core.kart import lateral_limit, tyre_wear, yaw_for_wear

    p = params.as_array()
    for yaw in np.linspace(0.0, 400.0, 41):
        assert tyre_wear(p, yaw) == pytest.approx(float(params.wear_from_yaw(yaw)), rel=1e-12)
    for wear in np.linspace(0.0, 0.99, 34):
        assert lateral_limit(p, wear) == pytest.approx(float(params.lateral_limit(wear)), rel=1e-12)
        assert yaw_for_wear(p, wear) == pytest.approx(params.yaw_for_wear(wear), rel=1e-12)
