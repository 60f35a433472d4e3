"""The compiled ``hypot`` and ``remainder`` are CPython's to the last bit (compiled controllers must give the very
numbers their Python did): a million seeded draws over several scales, ties and edge cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numba import njit

from sim_core.exact_math import py_hypot, py_remainder


@njit(cache=True)
def _both(a: np.ndarray, b: np.ndarray, divisor: float) -> tuple[np.ndarray, np.ndarray]:
    hypots, remainders = np.empty(a.size), np.empty(a.size)
    for i in range(a.size):
        hypots[i] = py_hypot(a[i], b[i])
        remainders[i] = py_remainder(a[i], divisor)
    return hypots, remainders


@pytest.mark.parametrize("scale", [1e-3, 1.0, 30.0, 1e5])
def test_a_quarter_million_draws_agree_with_cpython_bit_for_bit(scale: float) -> None:
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=250_000) * scale, rng.normal(size=250_000) * scale
    a[:500] = np.round(a[:500])  # whole numbers: exact squares, remainder ties
    hypots, remainders = _both(a, b, 2.0 * math.pi)
    xs, ys = a.tolist(), b.tolist()
    assert hypots.tolist() == [math.hypot(x, y) for x, y in zip(xs, ys, strict=True)]
    assert remainders.tolist() == [math.remainder(x, 2.0 * math.pi) for x in xs]


@given(st.floats(allow_nan=False, allow_infinity=True), st.floats(allow_nan=False, allow_infinity=True))
def test_hypot_of_any_two_floats_is_cpythons(x: float, y: float) -> None:
    assert py_hypot(x, y) == math.hypot(x, y)


@given(st.floats(allow_nan=False, allow_infinity=False), st.floats(min_value=1e-300, max_value=1e300))
def test_remainder_of_any_finite_float_is_cpythons(x: float, y: float) -> None:
    assert py_remainder(x, y) == math.remainder(x, y)
    assert math.copysign(1.0, py_remainder(x, y)) == math.copysign(1.0, math.remainder(x, y))


def test_ties_round_to_even_and_subnormals_scale() -> None:
    assert py_remainder(3.0, 2.0) == math.remainder(3.0, 2.0) == -1.0
    assert py_remainder(5.0, 2.0) == math.remainder(5.0, 2.0) == 1.0
    assert py_hypot(3.0, 4.0) == 5.0
    tiny = 5e-324
    assert py_hypot(tiny, tiny) == math.hypot(tiny, tiny)
    assert py_hypot(0.0, -0.0) == 0.0
