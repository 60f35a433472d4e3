"""Helpers for the tests of the built-in tracks' geometry: each track loaded once, the left normal of a tangent,
distances round a loop."""

from __future__ import annotations

from functools import cache

import numpy as np

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
