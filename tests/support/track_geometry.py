"""Helpers for the tests of tracks: each built-in track loaded once, the left normal of a tangent, distances round
a loop, and two tracks compared as the same race."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest

from sim_core.track import Track
from sim_core.track_io import get_track

BUILTINS = ("oval", "complex", "train-oval-small", "train-oval-large")
ALL_NAMES = tuple(n for b in BUILTINS for n in (b, f"{b}-reversed"))


@cache
def track(name: str) -> Track:
    """Built-in tracks are immutable: load each one once per test process."""
    return get_track(name)


def left_normal(tangent: np.ndarray) -> np.ndarray:
    """The unit normal to the left of the unit ``tangent`` (x, y)."""
    return np.array([-tangent[1], tangent[0]])


def wrapped_gap(a: float, b: float, length: float) -> float:
    """|a - b| on a loop of ``length``."""
    return abs((a - b + length / 2) % length - length / 2)


def assert_same_track(a: Track, b: Track, *, tol: float = 1e-6) -> None:
    """Same race: name, settings, checkpoints, sections, and the same centre line within ``tol`` metres."""
    assert a.name == b.name
    assert (a.laps, a.lane_change_limit, a.lane_fractions) == (b.laps, b.lane_change_limit, b.lane_fractions)
    assert a.n_checkpoints == b.n_checkpoints
    assert a.racing_lanes == b.racing_lanes
    for i, (ca, cb) in enumerate(zip(a.checkpoints, b.checkpoints, strict=True)):
        assert ca.centre == pytest.approx(cb.centre, abs=1e-4), f"checkpoint {i}"
        assert abs(math.remainder(ca.heading - cb.heading, 2 * math.pi)) < 1e-5, f"checkpoint {i}"
    for i, (sa, sb) in enumerate(zip(a.sections, b.sections, strict=True)):
        assert (sa.is_straight, sa.left_turn) == (sb.is_straight, sb.left_turn), f"section {i}"
        assert (sa.length, sa.inside_radius, sa.angle_deg) == pytest.approx(
            (sb.length, sb.inside_radius, sb.angle_deg), abs=1e-3
        ), f"section {i}"
    assert a.length == pytest.approx(b.length, abs=tol)
    np.testing.assert_allclose(a.checkpoint_s, b.checkpoint_s, atol=tol)
    assert a.centre_xy.shape == b.centre_xy.shape
    np.testing.assert_allclose(a.centre_xy, b.centre_xy, atol=tol)
