"""1-D motion between checkpoints: the time-of-travel model of the discrete game (paper section 4.1.2).

A kart covers ``distance`` starting at ``v0`` and arriving at ``v1``, with acceleration ``accel``, braking
``brake`` and a speed ceiling ``v_max`` on the way (top speed, or the cornering speed of the lane). The
fastest profile is accelerate -> cruise at ``v_max`` -> brake (trapezoid), or accelerate -> brake when the
distance is too short to reach ``v_max`` (triangle). Boundary conditions that cannot be met give -1.
"""

from __future__ import annotations

import math

from numba import njit

INFEASIBLE = -1.0


@njit(cache=True, inline="always")
def segment_time(distance: float, v0: float, v1: float, accel: float, brake: float, v_max: float) -> float:
    """Shortest time [s] to cover ``distance`` [m] from speed ``v0`` to ``v1`` [m/s], or -1 if impossible.

    The arrival speed must not exceed ``v_max``; entering above ``v_max`` means braking down to it first.
    """
    if distance <= 0.0 or v0 < 0.0 or v1 < 0.0 or v1 > v_max + 1e-9:
        return INFEASIBLE
    # reachability of the end speed at all
    if v1 > v0 and (v1 * v1 - v0 * v0) / (2.0 * accel) > distance + 1e-9:
        return INFEASIBLE
    if v0 > v1 and (v0 * v0 - v1 * v1) / (2.0 * brake) > distance + 1e-9:
        return INFEASIBLE
    # phase 1: reach v_max (accelerate, or brake if entering too fast); phase 3: from v_max to v1
    t1 = (v_max - v0) / accel if v_max >= v0 else (v0 - v_max) / brake
    t3 = (v_max - v1) / brake
    x1 = 0.5 * (v0 + v_max) * t1
    x3 = 0.5 * (v1 + v_max) * t3
    cruise = distance - x1 - x3
    if cruise >= 0.0:
        return t1 + cruise / v_max + t3
    if v0 > v_max:
        # too fast for the ceiling and too short to brake down to it
        return INFEASIBLE
    # triangle: accelerate to a peak below v_max, then brake to v1
    peak = math.sqrt((2.0 * distance * accel * brake + brake * v0 * v0 + accel * v1 * v1) / (accel + brake))
    if peak < v0 - 1e-9 or peak < v1 - 1e-9:
        return INFEASIBLE
    return (peak - v0) / accel + (peak - v1) / brake
