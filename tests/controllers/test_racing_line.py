"""The optimised racing line: inside the walls, faster than the hand-set lanes, and a sound speed profile."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from controllers.racing_line import handset_line, minimum_curvature_offsets, optimise_racing_line, speed_profile
from sim_core.params import PAPER_KART
from sim_core.track_builder import Curve, Straight, chain_track
from sim_core.track_io import get_track


@pytest.mark.parametrize("name", ["oval", "complex", "train-oval-small", "complex-reversed"])
def test_line_stays_margin_inside_the_walls(name: str) -> None:
    track = get_track(name)
    margin = 1.0
    line = optimise_racing_line(track, PAPER_KART, margin=margin)
    left = np.interp(line.s, track.centre_s, track.width_left, period=track.length)
    right = np.interp(line.s, track.centre_s, track.width_right, period=track.length)
    assert np.all(line.offset <= left - margin + 1e-6)
    assert np.all(line.offset >= -(right - margin) - 1e-6)
    assert len(line.checkpoint_lanes) == track.n_checkpoints
    assert all(1 <= lane <= 4 for lane in line.checkpoint_lanes)


@pytest.mark.parametrize("name", ["oval", "complex"])
def test_optimised_line_is_no_slower_than_the_handset_lanes(name: str) -> None:
    track = get_track(name)
    optimised = optimise_racing_line(track, PAPER_KART)
    handset = handset_line(track, PAPER_KART)
    assert optimised.lap_time <= handset.lap_time
    # and plausible: the paper's best laps are about 19-20 s (oval) and 32.5-34.5 s (complex)
    assert {"oval": 15.0, "complex": 28.0}[name] < optimised.lap_time < {"oval": 22.0, "complex": 40.0}[name]


def test_minimum_curvature_cuts_the_apex_of_a_single_corner() -> None:
    # a square with rounded corners: the minimum-curvature line runs wide (right, negative offsets) along the
    # straights and cuts to the inside (left, positive offsets) at each left corner's middle
    pieces = [Straight(10.0)] * 3 + [Curve(10.0, 45.0), Curve(10.0, 45.0)]
    track = chain_track("square", pieces * 4)
    s, offset = minimum_curvature_offsets(track, margin=1.0)
    corner_mid = track.checkpoint_s[4]  # boundary between the two 45 deg pieces of the first corner
    straight_mid = track.checkpoint_s[1] + 5.0
    at = lambda q: float(np.interp(q, s, offset, period=track.length))  # noqa: E731
    assert at(corner_mid) > 1.0
    assert at(straight_mid) < -1.5


def test_speed_profile_on_a_circle_is_the_cornering_speed() -> None:
    theta = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    radius = 10.0
    circle = np.stack([radius * np.cos(theta), radius * np.sin(theta)], axis=1)
    speed, lap_time = speed_profile(circle, PAPER_KART, wear=0.0)
    expected = np.sqrt(1.5 * 9.81 * radius)
    assert np.allclose(speed, expected, rtol=1e-3)
    assert lap_time == pytest.approx(2 * np.pi * radius / expected, rel=1e-3)


def test_speed_profile_respects_acceleration_and_braking() -> None:
    # a long straight closed by a tight turn: speed rises at no more than a and falls at no more than b
    track = chain_track(
        "hairpins", [Straight(10.0)] * 8 + [Curve(1.0, 90.0)] * 2 + [Straight(10.0)] * 8 + [Curve(1.0, 90.0)] * 2
    )
    line = optimise_racing_line(track, PAPER_KART)
    v = line.speed
    ds = np.linalg.norm(np.roll(line.xy, -1, axis=0) - line.xy, axis=1)
    dv2 = np.roll(v, -1) ** 2 - v**2
    assert np.all(dv2 <= 2 * PAPER_KART.acceleration * ds + 1e-6)
    assert np.all(-dv2 <= 2 * PAPER_KART.braking * ds + 1e-6)
    assert v.max() == pytest.approx(PAPER_KART.top_speed)


@settings(max_examples=300, deadline=None)
@given(s=hs.floats(min_value=-2000.0, max_value=4000.0, allow_nan=False))
def test_one_point_lookups_equal_np_interp_to_the_last_bit(s: float) -> None:
    """The trackers' one-point lookup (a bisection and the segment's slope) returns what np.interp returns, the
    same double: races are deterministic and every published result depends on it."""
    line = optimise_racing_line(get_track("complex"), PAPER_KART)
    for sample in (s, *line.s[:3].tolist(), float(line.s[-1])):
        assert line.offset_at(sample) == line.offset_at(np.array([sample]))[0]
        assert line.speed_at(sample) == line.speed_at(np.array([sample]))[0]
