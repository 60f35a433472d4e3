"""Kart dynamics: a kinematic bicycle with a lateral-acceleration limit that falls as the tyres wear.

One compiled function, :func:`kart_step`, advances one kart by one fixed step. The packed parameter
vector comes from :meth:`sim_core.params.KartParams.as_array`; its field order is
:data:`sim_core.params.KART_PARAM_FIELDS`.

Model (reference point: the centre of the kart, half the wheelbase from each axle)
---------------------------------------------------------------------------------
* front wheel angle ``delta = steer * max_steer_angle`` asks for the path curvature of the steady bicycle,
  ``kappa = 2 sin(beta) / wheelbase`` with the slip angle ``tan(beta) = tan(delta) / 2``;
* the tyres hold at most ``a_lat(wear) / v^2`` of curvature: above the cornering speed ``sqrt(a_lat / kappa)``
  of the commanded steer the kart brakes at its braking limit (traction control, as the paper describes)
  and understeers (the curvature it gets is the limit's);
* the slip angle ``beta`` is state: it moves toward the slip of the curvature the tyres hold, but never so
  fast that the direction of travel ``heading + beta`` turns by more than ``a_lat / v`` per second. So the
  path of the kart's centre never bends harder than the grip allows, whatever the inputs (a steer step
  included); the yaw rate is ``omega = 2 v sin(beta) / wheelbase``, at most ``a_lat / v`` (a slip left by a wall
  contact straightens out no faster), and ``|beta|`` stays within the full-lock slip;
* throttle > 0 accelerates with ``throttle * acceleration * curve(v)``, < 0 brakes with
  ``|throttle| * braking * curve(v)``; the unused part of the pedal coasts with ``coasting_drag``;
  from standstill a held brake reverses, up to ``reverse_speed``; speed never exceeds ``top_speed``.
  :func:`throttle_for_acceleration` inverts this, drag included, for drivers that command an acceleration;
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
P_WALL_YAW_RATE = 16

STANDSTILL = 1e-3  # [m/s] below this a kart counts as stopped (brake -> reverse, throttle -> forward)


@njit(cache=True, inline="always")
def tyre_wear(p: np.ndarray, accumulated_yaw: float) -> float:
    """Tyre-wear proportion in [0, 1] after ``accumulated_yaw`` [rad] of turning."""
    return min(1.0, p[P_WEAR_GAIN] * (1.0 - math.exp(-accumulated_yaw / p[P_WEAR_SCALE])))


@njit(cache=True, inline="always")
def yaw_for_wear(p: np.ndarray, wear: float) -> float:
    """Inverse of :func:`tyre_wear`: the accumulated yaw [rad] that gives ``wear`` (< wear_gain)."""
    return -p[P_WEAR_SCALE] * math.log(1.0 - wear / p[P_WEAR_GAIN])


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
        return min(new, p[P_TOP_SPEED])
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
def throttle_for_acceleration(p: np.ndarray, speed: float, acceleration: float) -> float:
    """The throttle in [-1, 1] that realises ``acceleration`` [m/s^2] at forward ``speed`` [m/s]: the inverse of
    :func:`longitudinal_speed`, coasting drag included (holding a speed takes throttle; coasting slows).

    Accelerations beyond the kart's limits saturate at full throttle or full brake. At standstill a
    deceleration asks for 0 (a held brake would reverse).
    """
    if acceleration != acceleration:
        return 0.0
    drag = p[P_COASTING_DRAG]
    if speed <= STANDSTILL and acceleration <= 0.0:
        return 0.0
    curve = _pedal_curve(p, speed)
    if acceleration >= -drag:
        throttle = (acceleration + drag) / (p[P_ACCELERATION] * curve + drag)
    else:
        throttle = (acceleration + drag) / (p[P_BRAKING] * curve - drag)
    return min(max(throttle, -1.0), 1.0)


@njit(cache=True, inline="always")
def max_slip(p: np.ndarray) -> float:
    """Slip angle [rad] of the steady bicycle at full lock: ``atan(tan(max_steer_angle) / 2)``."""
    return math.atan(0.5 * math.tan(p[P_MAX_STEER]))


@njit(cache=True, inline="always")
def kart_step(
    p: np.ndarray,
    x: float,
    y: float,
    heading: float,
    speed: float,
    slip: float,
    accumulated_yaw: float,
    steer: float,
    throttle: float,
    dt: float,
) -> tuple[float, float, float, float, float, float, float]:
    """Advance one kart by ``dt``: returns (x, y, heading, speed, slip, yaw_rate, accumulated_yaw)."""
    steer = clean_input(steer)
    throttle = clean_input(throttle)
    wear = tyre_wear(p, accumulated_yaw)
    a_lat = lateral_limit(p, wear)
    wheelbase = p[P_WHEELBASE]
    tan_beta = 0.5 * math.tan(steer * p[P_MAX_STEER])
    sin_beta_cmd = tan_beta / math.sqrt(1.0 + tan_beta * tan_beta)
    curvature_cmd = 2.0 * sin_beta_cmd / wheelbase  # [1/m] signed, of the centre's steady path
    new_speed = longitudinal_speed(p, speed, throttle, dt)
    curvature_abs = abs(curvature_cmd)
    if curvature_abs > 1e-9:
        corner_speed = math.sqrt(a_lat / curvature_abs)
        if abs(new_speed) > corner_speed:
            if abs(speed) > corner_speed:
                # traction control: already too fast for this steer, brake toward the cornering speed
                allowed = max(corner_speed, abs(speed) - p[P_BRAKING] * _pedal_curve(p, speed) * dt)
            else:
                allowed = corner_speed
            new_speed = math.copysign(min(allowed, abs(new_speed)), new_speed)
    v_abs = abs(new_speed)
    # the curvature the tyres hold at this speed (understeer beyond it)
    curvature = curvature_cmd
    if v_abs > 1e-6 and curvature_abs * v_abs * v_abs > a_lat:
        curvature = math.copysign(a_lat / (v_abs * v_abs), curvature_cmd)
    slip_target = math.asin(min(max(0.5 * wheelbase * curvature, -1.0), 1.0))
    # |slip| stays within the full-lock slip without a clip: the target is within it, and the new slip lies
    # between the old one and the target, or moves toward zero (walls clip the slip they set)
    if v_abs > 1e-6:
        # course (heading + slip) change over the step = omega(slip') dt + (slip' - slip), kept within
        # a_lat / v * dt; omega is linearised around the current slip (exact to second order in the change)
        k = 2.0 * new_speed * dt / wheelbase
        course_from_yaw = k * math.sin(slip)
        gain = 1.0 + k * math.cos(slip)
        # at the step's mean speed: the course change is driven between the old and the new speed
        budget = a_lat / max(0.5 * (abs(speed) + v_abs), 1e-6) * dt
        low = slip + (-budget - course_from_yaw) / gain
        high = slip + (budget - course_from_yaw) / gain
        new_slip = min(max(slip_target, low), high)
        yaw_rate = 2.0 * new_speed * math.sin(new_slip) / wheelbase
        yaw_cap = a_lat / v_abs
        if abs(yaw_rate) > yaw_cap:
            # the tyres cannot turn the body faster either (a slip left by a wall, or a speed-up while
            # turning): the yaw saturates and the slip alone keeps the course within its budget
            yaw_rate = math.copysign(yaw_cap, yaw_rate)
            turn = yaw_rate * dt
            new_slip = min(max(slip_target, slip - budget - turn), slip + budget - turn)
        slip = new_slip
    else:
        slip = slip_target
        yaw_rate = 0.0
    # the step's direction of travel is the end heading plus the end slip: consecutive courses then differ by
    # exactly the (budgeted) yaw and slip changes of the step
    course = heading + yaw_rate * dt + slip
    x += new_speed * math.cos(course) * dt
    y += new_speed * math.sin(course) * dt
    wrapped = heading + yaw_rate * dt + math.pi
    if not 0.0 < wrapped < 2.0 * math.pi:  # (inside, % would return it unchanged)
        wrapped %= 2.0 * math.pi
    heading = wrapped - math.pi
    accumulated_yaw += abs(yaw_rate) * dt
    return x, y, heading, new_speed, slip, yaw_rate, accumulated_yaw
