"""CPython's ``math.hypot`` and ``math.remainder`` in numba, to the last bit.

Compiled code that replaces a controller's Python must give the same numbers, or a race raced before and after
diverges (a race is chaotic: one last bit in a distance flips a lane choice a few seconds on). numba's own
``math.hypot`` is libm's, which differs from CPython's in about one call in 170 (CPython computes the norm with
compensated sums and a correction step, `Modules/mathmodule.c` ``vector_norm``); numba has no ``math.remainder``.
Everything else these kernels use (``+ - * /``, ``sqrt``, ``atan2``, ``pow``, float ``%``) is the same operation
in both. ``tests/sim_core/test_exact_math.py`` checks both functions against CPython on a million draws.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_VELTKAMP = 134217729.0  # 2^27 + 1: splits a double into two halves whose products are exact
_SMALLEST_NORMAL = 2.2250738585072014e-308


@njit(cache=True, inline="always")
def _product_error(x: float, y: float) -> float:
    """The rounding error of ``x * y``, exactly (Dekker's product; what ``fma(x, y, -x * y)`` returns)."""
    z = x * y
    t = _VELTKAMP * x
    x_hi = t - (t - x)
    x_lo = x - x_hi
    t = _VELTKAMP * y
    y_hi = t - (t - y)
    y_lo = y - y_hi
    return ((x_hi * y_hi - z) + x_hi * y_lo + x_lo * y_hi) + x_lo * y_lo


@njit(cache=True)
def py_hypot(x: float, y: float) -> float:
    """``math.hypot(x, y)`` as CPython computes it: the values scaled by a power of two, squared exactly, summed
    with compensation, the square root corrected by one Newton step."""
    ax, ay = abs(x), abs(y)
    if math.isinf(ax) or math.isinf(ay):
        return math.inf
    if math.isnan(ax) or math.isnan(ay):
        return math.nan
    largest = ax if ax > ay else ay
    if largest == 0.0:
        return largest
    _, exponent = math.frexp(largest)
    if exponent < -1023:  # subnormal: ldexp(1, -exponent) would overflow; make them normal first
        return _SMALLEST_NORMAL * py_hypot(ax / _SMALLEST_NORMAL, ay / _SMALLEST_NORMAL)
    scale = math.ldexp(1.0, -exponent)
    total, low_products, low_sums = 1.0, 0.0, 0.0
    for value in (ax * scale, ay * scale):
        square = value * value
        summed = total + square
        low_products += _product_error(value, value)
        low_sums += (total - summed) + square
        total = summed
    root = math.sqrt(total - 1.0 + (low_products + low_sums))
    square = -root * root
    summed = total + square
    low_products += _product_error(-root, root)
    low_sums += (total - summed) + square
    total = summed
    root += (total - 1.0 + (low_products + low_sums)) / (2.0 * root)
    return root / scale


@njit(cache=True)
def py_remainder(x: float, y: float) -> float:
    """``math.remainder(x, y)`` (IEEE 754 remainder: ``x - n y`` with n the integer nearest ``x / y``, ties to
    even) as CPython computes it, for finite ``x`` and non-zero ``y``."""
    absx, absy = abs(x), abs(y)
    m = np.fmod(absx, absy)
    c = absy - m
    if m < c:
        r = m
    elif m > c:
        r = -c
    else:
        r = m - 2.0 * np.fmod(0.5 * (absx - m), absy)
    return math.copysign(1.0, x) * r
