"""Kart dynamics: a kinematic bicycle with a lateral-acceleration limit that falls as the tyres wear.

One compiled function, :func:`kart_step`, advances one kart by one fixed step. The packed parameter
vector comes from :meth:`sim_core.params.KartParams.as_array`; its field order is
:data:`sim_core.params.KART_PARAM_FIELDS`.

Model (reference point: the centre of the kart, half the wheelbase from each axle)
---------------------------------------------------------------------------------
* front wheel angle ``delta = steer * max_steer_angle``; slip angle ``beta = atan(tan(delta) / 2)``;
* yaw rate ``omega = v cos(beta) tan(delta) / wheelbase``; the centre moves along ``heading + beta``;
* the path radius ``R = wheelbase / (cos(beta) |tan(delta)|)`` and the lateral limit ``a_lat(wear)`` give a
  cornering speed ``sqrt(a_lat R)``: above it the kart brakes at its braking limit (traction control, as the
  paper describes) and its yaw rate is capped at ``a_lat / v`` meanwhile (understeer);
* throttle > 0 accelerates with ``throttle * acceleration * curve(v)``, < 0 brakes with
  ``|throttle| * braking * curve(v)``; the unused part of the pedal coasts with ``coasting_drag``;
  from standstill a held brake reverses, up to ``reverse_speed``;
* tyre wear ``w = min(1, wear_gain (1 - exp(-A / wear_yaw_scale)))`` with ``A`` the accumulated |yaw| [rad].
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim_core.params import GRAVITY

# indices into the packed parameter vector (order of KART_PARAM_FIELDS)
P_TOP_SPEED = 0
P_REVERSE_SPEED = 1
P_ACCELERATION = 2
P_BRAKING = 3
P_REVERSE_ACCELERATION = 4
P_LOW_SPEED_GAIN = 5
P_COASTING_DRAG = 6
P_WHEELBASE = 7
P_MAX_STEER = 8
P_G_FRESH = 9
P_G_WORN = 10
P_WEAR_SCALE = 11
P_WEAR_GAIN = 12
P_HALF_LENGTH = 13
P_RADIUS = 14
P_WALL_FRICTION = 15

STANDSTILL = 1e-3  # [m/s] below this a kart counts as stopped (brake -> reverse, throttle -> forward)


@njit(cache=True, inline="always")
def tyre_wear(p: np.ndarray, accumulated_yaw: float) -> float:
    """Tyre-wear proportion in [0, 1] after ``accumulated_yaw`` [rad] of turning."""
    return min(1.0, p[P_WEAR_GAIN] * (1.0 - math.exp(-accumulated_yaw / p[P_WEAR_SCALE])))


@njit(cache=True, inline="always")
def lateral_limit(p: np.ndarray, wear: float) -> float:
    """Lateral acceleration limit [m/s^2] at tyre wear ``wear``."""
    return (p[P_G_WORN] + (1.0 - wear) * (p[P_G_FRESH] - p[P_G_WORN])) * GRAVITY


@njit(cache=True, inline="always")
def _pedal_curve(p: np.ndarray, speed: float) -> float:
    ratio = min(abs(speed) / p[P_TOP_SPEED], 1.0)
    return p[P_LOW_SPEED_GAIN] + (1.0 - p[P_LOW_SPEED_GAIN]) * ratio * ratio


@njit(cache=True, inline="always")
def clean_input(value: float) -> float:
    """Clamp a control input to [-1, 1]; NaN counts as 0."""
    if value != value:
        return 0.0
    return min(max(value, -1.0), 1.0)


@njit(cache=True, inline="always")
def longitudinal_speed(p: np.ndarray, speed: float, throttle: float, dt: float) -> float:
    """Speed [m/s] after one step of ``throttle`` in [-1, 1], before the cornering limit."""
    curve = _pedal_curve(p, speed)
    drag = p[P_COASTING_DRAG]
    if speed > STANDSTILL or (speed >= -STANDSTILL and throttle >= 0.0):
        # moving forward (or starting forward)
        if throttle >= 0.0:
            accel = throttle * p[P_ACCELERATION] * curve - (1.0 - throttle) * drag
        else:
            accel = throttle * p[P_BRAKING] * curve - (1.0 + throttle) * drag
        new = speed + accel * dt
        if new < 0.0:
            new = 0.0
        return min(new, p[P_TOP_SPEED]) if speed <= p[P_TOP_SPEED] else max(min(new, speed), p[P_TOP_SPEED])
    # moving backwards (or starting backwards with the brake held)
    if throttle <= 0.0:
        accel = throttle * p[P_REVERSE_ACCELERATION] + (1.0 + throttle) * drag * (1.0 if speed < -STANDSTILL else 0.0)
    else:
        accel = throttle * p[P_BRAKING] * curve + (1.0 - throttle) * drag
    new = speed + accel * dt
    if speed < -STANDSTILL and new > 0.0:
        new = 0.0
    return max(new, -p[P_REVERSE_SPEED])


@njit(cache=True, inline="always")
def kart_step(
    p: np.ndarray,
    x: float,
    y: float,
    heading: float,
    speed: float,
    accumulated_yaw: float,
    steer: float,
    throttle: float,
    dt: float,
) -> tuple[float, float, float, float, float, float]:
    """Advance one kart by ``dt``: returns (x, y, heading, speed, yaw_rate, accumulated_yaw)."""
    steer = clean_input(steer)
    throttle = clean_input(throttle)
    wear = tyre_wear(p, accumulated_yaw)
    a_lat = lateral_limit(p, wear)
    delta = steer * p[P_MAX_STEER]
    tan_delta = math.tan(delta)
    tan_beta = 0.5 * tan_delta
    cos_beta = 1.0 / math.sqrt(1.0 + tan_beta * tan_beta)
    sin_beta = tan_beta * cos_beta
    new_speed = longitudinal_speed(p, speed, throttle, dt)
    curvature = cos_beta * abs(tan_delta) / p[P_WHEELBASE]  # [1/m] of the centre's path
    if curvature > 1e-9:
        corner_speed = math.sqrt(a_lat / curvature)
        if abs(new_speed) > corner_speed:
            if abs(speed) > corner_speed:
                # traction control: already too fast for this steer, brake toward the cornering speed
                allowed = max(corner_speed, abs(speed) - p[P_BRAKING] * _pedal_curve(p, speed) * dt)
            else:
                allowed = corner_speed
            new_speed = math.copysign(min(allowed, abs(new_speed)), new_speed)
    yaw_rate = new_speed * cos_beta * tan_delta / p[P_WHEELBASE]
    if abs(new_speed) > 1e-6:
        cap = a_lat / abs(new_speed)
        if abs(yaw_rate) > cap:
            yaw_rate = math.copysign(cap, yaw_rate)
    mid_heading = heading + 0.5 * yaw_rate * dt
    cos_mid, sin_mid = math.cos(mid_heading), math.sin(mid_heading)
    x += new_speed * (cos_mid * cos_beta - sin_mid * sin_beta) * dt
    y += new_speed * (sin_mid * cos_beta + cos_mid * sin_beta) * dt
    wrapped = heading + yaw_rate * dt + math.pi
    if not 0.0 < wrapped < 2.0 * math.pi:  # (inside, % would return it unchanged)
        wrapped %= 2.0 * math.pi
    heading = wrapped - math.pi
    accumulated_yaw += abs(yaw_rate) * dt
    return x, y, heading, new_speed, yaw_rate, accumulated_yaw
