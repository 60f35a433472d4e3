"""Positions along the built-in tracks (sim_core.track): ``project`` inverts ``point_at``, the sign of the
lateral offset, ``point_at`` against the segment interpolation written out, and the gap along the lap."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support.track_geometry import ALL_NAMES, left_normal, track, wrapped_gap

from sim_core.params import PAPER_KART
from sim_core.track import CENTRE_SAMPLE_SPACING, Track
from sim_core.track_io import get_track


def _road_point(name: str, s_frac: float, lateral: float) -> tuple[Track, float, float, np.ndarray]:
    """(track, s, d, point d metres left of the centre line at s), |d| up to the local wall width - 0.1 m."""
    tr = track(name)
    s = min(s_frac * tr.length, np.nextafter(tr.length, 0.0))
    left, right = tr.half_widths_at(s)
    d = lateral * (left - 0.1) if lateral >= 0 else lateral * (right - 0.1)
    point, tangent = tr.point_at(s)
    return tr, s, d, point + d * left_normal(tangent)


def _curvature_toward(tr: Track, s: float, d: float) -> float:
    """Largest curvature [1/m] toward the side of ``d`` within +-2 m of ``s`` (0 on the outside of a bend)."""
    i = int(np.searchsorted(tr.centre_s, s, side="right") - 1)
    window = np.arange(i - 8, i + 9) % len(tr.centre_s)
    return float(np.max(np.maximum(tr.centre_curvature[window] * np.sign(d), 0.0)))


@settings(max_examples=400, deadline=None, derandomize=True)
@given(
    name=st.sampled_from(ALL_NAMES),
    s_frac=st.floats(0.0, 1.0, exclude_max=True),
    lateral=st.floats(-1.0, 1.0),
)
def test_project_inverts_point_at(name: str, s_frac: float, lateral: float) -> None:
    """``project(point_at(s) + d * normal) == (s, d)`` within 1 cm.

    Where the point is on the outside of a bend (or on a straight) the answer is unique and must be exact to
    1 cm. On the inside of a bend the nearest point of the 0.25 m polyline is ambiguous near its vertices and
    the nearest-point problem is ill-conditioned close to the centre of curvature (ds/dx = 1 / (1 - k d)),
    so s may legitimately move by up to about ``|d| k h / (1 - k |d|)`` (h = sample spacing; 0.36 m at the
    inner wall of complex's hairpins, a few cm on the ovals); there the result must still be a true foot
    point: ``point_at(s') + d' * normal(s')`` gives back the point. (On the outside a foot can sit on a vertex,
    where point_at takes the next segment's tangent, so that reconstruction is only checked inside.)
    """
    tr, s, d, point = _road_point(name, s_frac, lateral)
    s2, d2 = tr.project(point)
    assert 0.0 <= s2 < tr.length
    k = _curvature_toward(tr, s, d)
    ds = wrapped_gap(s2, s, tr.length)
    if k * abs(d) < 1e-3:
        assert ds < 0.01 and abs(d2 - d) < 0.01, (s, d, s2, d2)
    else:
        h = CENTRE_SAMPLE_SPACING
        assert ds < 0.01 + 1.5 * abs(d) * k * h / (1 - k * abs(d)), (s, d, s2, d2)
        assert abs(d2 - d) < 0.01 + abs(d) * (k * h) ** 2 / (1 - k * abs(d)), (s, d, s2, d2)
        foot, tangent = tr.point_at(s2)
        assert np.linalg.norm(foot + d2 * left_normal(tangent) - point) < 0.01


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    name=st.sampled_from(ALL_NAMES),
    pick=st.integers(0, 10_000),
    along=st.floats(0.2, 0.8),
    d=st.floats(-4.0, 4.0),
)
def test_project_exact_on_straights(name: str, pick: int, along: float, d: float) -> None:
    """On straight sections (away from their ends) project inverts point_at to 1 cm in s and d."""
    tr = track(name)
    straights = np.flatnonzero(tr.straight_flags)
    c = int(straights[pick % len(straights)])
    s0 = float(tr.checkpoint_s[c])
    s1 = float(tr.checkpoint_s[(c + 1) % tr.n_checkpoints])
    s1 = s1 if s1 > s0 else s1 + tr.length
    s = (s0 + along * (s1 - s0)) % tr.length
    point, tangent = tr.point_at(s)
    s2, d2 = tr.project(point + d * left_normal(tangent))
    assert wrapped_gap(s2, s, tr.length) < 0.01
    assert d2 == pytest.approx(d, abs=0.01)


def test_project_sign_convention() -> None:
    """d is positive to the left: on the counter-clockwise oval, towards the infield."""
    tr = track("oval")
    s = float(tr.checkpoint_s[1])
    point, tangent = tr.point_at(s)
    assert tangent == pytest.approx([0.0, 1.0], abs=1e-6)  # first straight heads +y
    s2, d2 = tr.project(point + np.array([-2.0, 0.0]))  # left of +y is -x
    assert d2 == pytest.approx(2.0, abs=1e-6)
    assert s2 == pytest.approx(s, abs=1e-6)
    assert tr.project(point + np.array([3.0, 0.0]))[1] == pytest.approx(-3.0, abs=1e-6)
    rev = track("oval-reversed")
    assert rev.project(point + np.array([-2.0, 0.0]))[1] == pytest.approx(-2.0, abs=1e-6)


def test_the_gap_along_the_track_takes_the_nearer_way_round_the_lap() -> None:
    """Hand-checked on the oval: 10 m ahead, 10 m behind, and across the start line either way."""
    track = get_track("oval")
    length = track.length
    assert track.gap(100.0, 110.0) == pytest.approx(10.0)
    assert track.gap(110.0, 100.0) == pytest.approx(-10.0)
    assert track.gap(length - 5.0, 3.0) == pytest.approx(8.0)  # just over the line: ahead
    assert track.gap(3.0, length - 5.0) == pytest.approx(-8.0)
    assert PAPER_KART.body_length == pytest.approx(2.0)  # the capsule: 2 x (0.55 + 0.45) m


@settings(max_examples=200, deadline=None)
@given(s=st.floats(min_value=-500.0, max_value=3000.0, allow_nan=False))
def test_point_at_equals_the_segment_interpolation(s: float) -> None:
    """point_at (segments looked up from a table) against the interpolation written out: the sample before
    ``s``, the next one, and the unit vector between them, to the last bit."""
    track = get_track("complex")
    point, tangent = track.point_at(s)
    wrapped = s % track.length
    i = int(np.searchsorted(track.centre_s, wrapped, side="right") - 1)
    j = (i + 1) % len(track.centre_s)
    end = track.centre_s[j] if j else track.length
    a, b = track.centre_xy[i], track.centre_xy[j]
    u = (wrapped - track.centre_s[i]) / max(end - track.centre_s[i], 1e-12)
    assert np.array_equal(point, a + u * (b - a))
    assert np.array_equal(tangent, (b - a) / np.linalg.norm(b - a))
    assert math.isclose(float(np.hypot(*tangent)), 1.0, rel_tol=1e-12)
