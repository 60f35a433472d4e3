"""Geometry of the built-in tracks (sim_core.track): spec conformance, lanes, reversal, walls (projection onto
the centre line: ``test_track_projection.py``)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from support.track_geometry import ALL_NAMES, BUILTINS, track, wrapped_gap

from sim_core.track import CENTRE_SAMPLE_SPACING, Section, Track
from sim_core.track_builder import INNER_WALL_CURVATURE_MARGIN
from sim_core.track_io import builtin_track_names, get_track

SPEC_DIR = Path(__file__).resolve().parents[2].parent / "shared" / "spec" / "tracks"
LANE_OFFSETS = (3.5, 1.25, -1.25, -3.5)  # [m] left-positive, lane 1 leftmost, on a 10 m road


def physical_checkpoint(original: Track, reversed_track: Track, j: int) -> int:
    """Index in ``original`` of the checkpoint at the same place as ``reversed_track``'s checkpoint ``j``."""
    centre = np.array(reversed_track.checkpoints[j].centre)
    gaps = [np.linalg.norm(centre - np.array(cp.centre)) for cp in original.checkpoints]
    assert min(gaps) < 1e-9, f"reversed checkpoint {j} is not at any original checkpoint"
    return int(np.argmin(gaps))


def segment_crossings(p: np.ndarray, q: np.ndarray, *, same: bool) -> int:
    """Number of proper crossings between the closed polylines ``p`` and ``q`` (segments touching at a shared
    vertex of the same polyline are not counted)."""
    p0, p1 = p, np.roll(p, -1, axis=0)
    q0, q1 = q, np.roll(q, -1, axis=0)

    def cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - (a[..., 1] - o[..., 1]) * (b[..., 0] - o[..., 0])

    count = 0
    m = len(q)
    for start in range(0, len(p), 256):
        a0, a1 = p0[start : start + 256, None, :], p1[start : start + 256, None, :]
        b0, b1 = q0[None, :, :], q1[None, :, :]
        hit = (cross(a0, a1, b0) * cross(a0, a1, b1) < 0) & (cross(b0, b1, a0) * cross(b0, b1, a1) < 0)
        if same:
            i = np.arange(start, start + len(a0))[:, None]
            j = np.arange(m)[None, :]
            hit &= ((i - j) % m > 1) & ((j - i) % m > 1)
        count += int(hit.sum())
    return count


# --------------------------------------------------------------------------- 1. the paper's tracks vs the spec
def load_spec(name: str) -> dict:
    path = SPEC_DIR / f"{name}.json"
    if not path.exists():
        pytest.skip(f"track spec {path} not found (the spec lives in ../shared/spec/tracks beside the repo)")
    return json.loads(path.read_text())


SPEC_CASES = [("oval", 24, 4, 3), ("complex", 41, 3, 4)]  # name, checkpoints, laps, lane-change limit


@pytest.mark.parametrize(("name", "n_checkpoints", "laps", "lane_limit"), SPEC_CASES)
def test_race_settings_match_spec(name: str, n_checkpoints: int, laps: int, lane_limit: int) -> None:
    spec = load_spec(name)
    tr = track(name)
    assert tr.n_checkpoints == len(spec["sections"]) == n_checkpoints
    assert tr.laps == spec["meta"]["env"]["laps"] == laps
    assert tr.lane_change_limit == spec["meta"]["env"]["MaxLaneChanges"] == lane_limit
    assert tr.n_lanes == 4


@pytest.mark.parametrize("name", [c[0] for c in SPEC_CASES])
def test_checkpoint_and_lane_positions_match_spec(name: str) -> None:
    spec = load_spec(name)
    tr = track(name)
    for c, sec in enumerate(spec["sections"]):
        centre = tr.checkpoint_frame(c)[0]
        assert np.linalg.norm(centre - np.array(sec["center_xy"])) < 0.5, f"checkpoint {c} centre"
        for k in range(1, 5):
            gap = np.linalg.norm(tr.lane_point(c, k) - np.array(sec[f"lane{k}_xy"]))
            assert gap < 0.5, f"checkpoint {c} lane {k} is {gap:.3f} m from the spec"


@pytest.mark.parametrize("name", [c[0] for c in SPEC_CASES])
def test_centre_line_heading_at_checkpoints_matches_spec(name: str) -> None:
    spec = load_spec(name)
    tr = track(name)
    for c, sec in enumerate(spec["sections"]):
        expected = math.radians(sec["heading_ccw_from_x_deg"])
        assert abs(math.remainder(tr.checkpoints[c].heading - expected, 2 * math.pi)) < 1e-6
        tangent = tr.point_at(float(tr.checkpoint_s[c]))[1]
        along = math.atan2(tangent[1], tangent[0])
        assert abs(math.degrees(math.remainder(along - expected, 2 * math.pi))) < 2.0, f"checkpoint {c}"


@pytest.mark.parametrize("name", [c[0] for c in SPEC_CASES])
def test_sections_match_spec(name: str) -> None:
    spec = load_spec(name)
    tr = track(name)
    assert tr.racing_lanes == tuple(sec["optimalLane"] for sec in spec["sections"])
    for c, (ours, theirs) in enumerate(zip(tr.sections, spec["sections"], strict=True)):
        assert ours.is_straight == theirs["is_straight"], f"section {c}"
        if ours.is_straight:
            assert ours.length == pytest.approx(theirs["trackLength"]), f"section {c}"
            continue
        assert ours.inside_radius == pytest.approx(theirs["trackInsideRadius"]), f"section {c}"
        assert ours.angle_deg == pytest.approx(theirs["turnDegrees"]), f"section {c}"
        assert ours.left_turn == theirs["leftTurn"], f"section {c}"


def test_spec_tracks_have_both_kinds_of_sections() -> None:
    """Guards the per-section checks above against a track that is all straights."""
    for name in ("oval", "complex"):
        flags = track(name).straight_flags
        assert flags.any() and not flags.all()
    complex_turns = {s.left_turn for s in track("complex").sections if not s.is_straight}
    assert complex_turns == {True, False}


# --------------------------------------------------------------------------- centre line vs nominal sections
@pytest.mark.parametrize("name", ALL_NAMES)
def test_curve_sections_bend_the_nominal_way(name: str) -> None:
    """Along every curve section the centre line turns in the section's direction; straights barely turn."""
    tr = track(name)
    for c, sec in enumerate(tr.sections):
        s0 = tr.checkpoint_s[c]
        s1 = tr.checkpoint_s[(c + 1) % tr.n_checkpoints]
        s1 = s1 if s1 > s0 else s1 + tr.length
        headings = [tr.point_at(float(s))[1] for s in np.linspace(s0 + 0.01, s1 - 0.01, 60)]
        angles = np.unwrap([math.atan2(t[1], t[0]) for t in headings])
        turn = math.degrees(angles[-1] - angles[0])
        if sec.is_straight:
            assert abs(turn) < 5.0, f"straight section {c} turns {turn:.1f} deg"
        else:
            assert (turn > 10.0) if sec.left_turn else (turn < -10.0), f"curve section {c} turns {turn:.1f} deg"


@pytest.mark.parametrize("name", ["oval", "train-oval-small", "train-oval-large"])
def test_modular_ovals_follow_their_pieces(name: str) -> None:
    """The ovals are 10 m straights and 45 deg constant-radius pieces: lap length and turns match them."""
    tr = track(name)
    nominal = sum(sec.length for sec in tr.sections)
    assert tr.length == pytest.approx(nominal, rel=0.01)
    for c, sec in enumerate(tr.sections):
        if sec.is_straight:
            continue
        assert sec.length > 0, f"section {c}"
        centre_radius = sec.inside_radius + tr.nominal_width / 2
        assert sec.length == pytest.approx(math.radians(sec.angle_deg) * centre_radius), f"section {c}"
    assert sum(sec.angle_deg * (1 if sec.left_turn else -1) for sec in tr.sections if not sec.is_straight) == 360


# --------------------------------------------------------------------------- 2. lanes
@pytest.mark.parametrize("name", ALL_NAMES)
def test_four_lanes_at_nominal_offsets(name: str) -> None:
    tr = track(name)
    assert tr.n_lanes == 4
    assert tr.nominal_width == pytest.approx(10.0)
    for c in range(tr.n_checkpoints):
        offsets = tr.lane_offsets(c)
        np.testing.assert_allclose(offsets, LANE_OFFSETS, atol=1e-9, err_msg=f"checkpoint {c}")
        centre, normal = tr.checkpoint_frame(c)
        for k, offset in enumerate(LANE_OFFSETS, start=1):
            assert tr.lane_id(c, offset) == k
            assert tr.lane_id(c, offset + 0.5) == k and tr.lane_id(c, offset - 0.5) == k
            np.testing.assert_allclose(tr.lane_point(c, k), centre + offset * normal, atol=1e-9)
    assert tr.lane_id(0, 100.0) == 1 and tr.lane_id(0, -100.0) == 4


@pytest.mark.parametrize("name", ALL_NAMES)
def test_lane_points_inside_walls(name: str) -> None:
    tr = track(name)
    points = tr.lane_points()
    assert points.shape == (tr.n_checkpoints, 4, 2)
    for c in range(tr.n_checkpoints):
        for k in range(1, 5):
            s, d = tr.project(points[c, k - 1])
            assert wrapped_gap(s, tr.checkpoint_s[c], tr.length) < 0.25  # see test_project_inverts_point_at
            assert d == pytest.approx(LANE_OFFSETS[k - 1], abs=0.02)
            left, right = tr.half_widths_at(s)
            assert -right + 0.3 < d < left - 0.3, f"checkpoint {c} lane {k}: d={d:.2f}, walls +{left:.2f}/-{right:.2f}"
            assert tr.lane_of_position(points[c, k - 1]) == k


def test_lane_ordering_is_left_to_right() -> None:
    """Lane 1 is on the left of the driving direction: on the counter-clockwise oval that is the inside."""
    tr = track("oval")
    centroid = tr.centre_xy.mean(axis=0)
    for c in range(tr.n_checkpoints):
        dist = [np.linalg.norm(tr.lane_point(c, k) - centroid) for k in range(1, 5)]
        assert dist[0] < dist[1] < dist[2] < dist[3]


def test_lane_point_rejects_bad_lane() -> None:
    tr = track("oval")
    for lane in (0, 5, -1):
        with pytest.raises(ValueError, match="lane"):
            tr.lane_point(0, lane)
    np.testing.assert_allclose(tr.lane_point(tr.n_checkpoints + 3, 2), tr.lane_point(3, 2))


def test_lane_radius_model() -> None:
    left = Section(is_straight=False, inside_radius=15.0, angle_deg=45.0, left_turn=True)
    right = left.reversed()
    assert not right.left_turn and right.inside_radius == 15.0 and right.angle_deg == 45.0
    assert [left.lane_radius(k, 4, 10.0) for k in range(1, 5)] == [15.0, 17.5, 20.0, 22.5]
    assert [right.lane_radius(k, 4, 10.0) for k in range(1, 5)] == [22.5, 20.0, 17.5, 15.0]
    straight = Section(is_straight=True, length=10.0)
    assert straight.reversed() == straight
    assert straight.lane_radius(1, 4, 10.0) == 0.0


# --------------------------------------------------------------------------- 3. reversal
@pytest.mark.parametrize("name", BUILTINS)
def test_reversing_twice_is_identity(name: str) -> None:
    tr = track(name)
    back = tr.reversed().reversed()
    assert back.name == tr.name
    np.testing.assert_allclose(back.centre_xy, tr.centre_xy, atol=1e-9)
    np.testing.assert_allclose(back.centre_s, tr.centre_s, atol=1e-9)
    np.testing.assert_allclose(back.checkpoint_s, tr.checkpoint_s, atol=1e-9)
    np.testing.assert_allclose(back.width_left, tr.width_left, atol=1e-12)
    np.testing.assert_allclose(back.width_right, tr.width_right, atol=1e-12)
    assert back.length == pytest.approx(tr.length, abs=1e-9)
    assert back.sections == tr.sections
    assert back.racing_lanes == tr.racing_lanes
    assert back.lane_fractions == tr.lane_fractions
    for a, b in zip(back.checkpoints, tr.checkpoints, strict=True):
        assert a.centre == b.centre
        assert abs(math.remainder(a.heading - b.heading, 2 * math.pi)) < 1e-9


@pytest.mark.parametrize("name", BUILTINS)
def test_reversed_track_is_the_same_circuit_backwards(name: str) -> None:
    tr = track(name)
    rev = track(f"{name}-reversed")
    assert rev.name == f"{name}-reversed"
    assert rev.reversed().name == name
    assert rev.length == pytest.approx(tr.length, abs=1e-9)
    assert (rev.laps, rev.lane_change_limit, rev.n_checkpoints) == (tr.laps, tr.lane_change_limit, tr.n_checkpoints)
    # same centre line, driven the other way; sign of the curvature flips
    np.testing.assert_allclose(np.sort(rev.centre_xy, axis=0), np.sort(tr.centre_xy, axis=0), atol=1e-12)
    assert rev.checkpoints[0].centre == tr.checkpoints[0].centre
    assert rev.centre_s[0] == 0.0 and np.all(np.diff(rev.centre_s) > 0)
    n = tr.n_checkpoints
    for j in range(n):
        m = physical_checkpoint(tr, rev, j)
        assert abs(math.remainder(rev.checkpoints[j].heading - tr.checkpoints[m].heading - math.pi, 2 * math.pi)) < 1e-9
        # progress from the start line is measured the other way round
        assert rev.checkpoint_s[j] == pytest.approx((tr.length - tr.checkpoint_s[m]) % tr.length, abs=1e-9)
        # lane 1 of the reversed track is where lane 4 of the original is, and so on
        for k in range(1, 5):
            gap = np.linalg.norm(rev.lane_point(j, k) - tr.lane_point(m, 5 - k))
            assert gap < 0.05, f"reversed checkpoint {j} lane {k} is {gap:.3f} m from original {m} lane {5 - k}"
        # the road from reversed j to j+1 is the original road between the same two places, other way round
        m_next = physical_checkpoint(tr, rev, (j + 1) % n)
        assert m_next == (m - 1) % n
        old = tr.sections[m_next]
        new = rev.sections[j]
        assert new.is_straight == old.is_straight
        assert new.length == old.length and new.inside_radius == old.inside_radius
        assert new.angle_deg == old.angle_deg
        if not new.is_straight:
            assert new.left_turn != old.left_turn
            assert [new.lane_radius(k, 4, 10.0) for k in range(1, 5)] == [
                old.lane_radius(5 - k, 4, 10.0) for k in range(1, 5)
            ]
        # the hand-set target lane on arriving at a place is mirrored (it is stored on the section before it)
        old_target = tr.racing_lanes[(m - 1) % n]
        new_target = rev.racing_lanes[(j - 1) % n]
        assert new_target == (None if old_target is None else 5 - old_target)


def test_reversed_oval_turns_right() -> None:
    rev = get_track("oval-reversed")
    assert rev.name == "oval-reversed"
    curves = [s for s in rev.sections if not s.is_straight]
    assert curves and not any(s.left_turn for s in curves)
    assert all(s.left_turn for s in track("oval").sections if not s.is_straight)
    # turning right everywhere: the signed curvature integrates to -2 pi over a lap
    total = float(np.sum(rev.centre_curvature) * rev.length / len(rev.centre_s))
    assert total == pytest.approx(-2 * math.pi, abs=0.05)


# --------------------------------------------------------------------------- 4. training ovals
def test_training_ovals_exist_and_differ_in_size() -> None:
    assert set(BUILTINS) <= set(builtin_track_names())
    small, large = track("train-oval-small"), track("train-oval-large")
    assert large.length > 1.5 * small.length
    small_box = np.ptp(small.centre_xy, axis=0)
    large_box = np.ptp(large.centre_xy, axis=0)
    assert np.all(large_box > small_box + 10.0)
    radius = {t.name: {s.inside_radius for s in t.sections if not s.is_straight} for t in (small, large)}
    assert radius == {"train-oval-small": {10.0}, "train-oval-large": {20.0}}


def test_the_narrow_training_circuit_is_6_m_wide_with_180_degree_hairpins_both_ways() -> None:
    tr = track("train-narrow-hairpins")
    np.testing.assert_allclose(tr.lane_half_left + tr.lane_half_right, 6.0)
    curves = [s for s in tr.sections if not s.is_straight]
    turned = {r: sum(s.angle_deg for s in curves if s.inside_radius == r and s.left_turn) for r in (1.0, 2.0)}
    assert turned == {1.0: 180.0, 2.0: 180.0}
    assert any(not s.left_turn for s in curves)  # the kinks turn right
    for lane, offset in enumerate(tr.lane_offsets(0), start=1):  # four lanes across the 6 m, inside the walls
        assert tr.lane_id(0, float(offset)) == lane and abs(offset) < 3.0 - 0.3
    reverse = track("train-narrow-hairpins-reversed")
    assert sum(s.angle_deg for s in reverse.sections if not s.is_straight and not s.left_turn) >= 360.0


@pytest.mark.parametrize("name", [*ALL_NAMES, "train-narrow-hairpins", "train-narrow-hairpins-reversed"])
def test_track_is_closed_and_continuous(name: str) -> None:
    tr = track(name)
    for poly in (tr.centre_xy, tr.left_wall, tr.right_wall):
        steps = np.linalg.norm(np.diff(np.vstack([poly, poly[:1]]), axis=0), axis=1)
        assert steps.max() < 1.0, "a polyline jumps (or does not close on itself)"
    steps = np.linalg.norm(np.diff(np.vstack([tr.centre_xy, tr.centre_xy[:1]]), axis=0), axis=1)
    assert steps.sum() == pytest.approx(tr.length, rel=1e-3)
    assert np.all(np.abs(steps - CENTRE_SAMPLE_SPACING) < 0.01)
    assert np.all(np.diff(tr.checkpoint_s) > 0) and 0 <= tr.checkpoint_s[0] < tr.checkpoint_s[-1] < tr.length


@pytest.mark.parametrize("name", [*BUILTINS, "train-narrow-hairpins"])
def test_walls_do_not_cross(name: str) -> None:
    tr = track(name)
    assert segment_crossings(tr.left_wall, tr.left_wall, same=True) == 0
    assert segment_crossings(tr.right_wall, tr.right_wall, same=True) == 0
    assert segment_crossings(tr.left_wall, tr.right_wall, same=False) == 0
    assert segment_crossings(tr.centre_xy, tr.left_wall, same=False) == 0


def test_crossing_check_detects_a_fold() -> None:
    """The helper above finds the loop a wall makes when offset further than the radius of curvature."""
    angle = np.linspace(0, 2 * np.pi, 200, endpoint=False) + 0.01  # no vertex at the crossing point
    circle = np.stack([10 * np.cos(angle), 10 * np.sin(angle)], axis=1)
    assert segment_crossings(circle, circle, same=True) == 0
    figure_eight = np.stack([10 * np.sin(angle), 5 * np.sin(2 * angle)], axis=1)
    assert segment_crossings(figure_eight, figure_eight, same=True) > 0


@pytest.mark.parametrize("name", ALL_NAMES)
def test_walls_are_where_the_widths_say(name: str) -> None:
    """Every wall sample projects back onto its own centre sample at the local width: no fold, no overlap."""
    tr = track(name)
    step = 3  # every third sample keeps this fast
    for wall, width, sign in ((tr.left_wall, tr.width_left, 1.0), (tr.right_wall, tr.width_right, -1.0)):
        for i in range(0, len(wall), step):
            s, d = tr.project(wall[i])
            assert abs(d - sign * width[i]) < 0.05, f"{name} sample {i}: d={d:.3f}, width={width[i]:.3f}"
            assert wrapped_gap(s, tr.centre_s[i], tr.length) < 1.0


# --------------------------------------------------------------------------- 5. walls never fold
@pytest.mark.parametrize("name", ALL_NAMES)
def test_inner_wall_inside_radius_of_curvature(name: str) -> None:
    tr = track(name)
    k = tr.centre_curvature
    for width, side in ((tr.width_left, 1.0), (tr.width_right, -1.0)):
        inner = side * k > 0
        ratio = width[inner] * np.abs(k[inner])  # width / local radius
        assert ratio.max() < 1.0
        assert ratio.max() <= INNER_WALL_CURVATURE_MARGIN + 0.01
    assert np.all(tr.width_left > 0) and np.all(tr.width_right > 0)
    assert np.all(tr.width_left <= tr.lane_half_left + 1e-12)
    assert np.all(tr.width_right <= tr.lane_half_right + 1e-12)


def test_hairpins_narrow_the_inside_wall_only() -> None:
    tr = track("complex")
    assert tr.width_left.min() < 4.5 and tr.width_right.min() < 4.5  # radius-1 m hairpins both ways
    k = tr.centre_curvature
    narrowed_left = tr.width_left < tr.lane_half_left - 1e-9
    assert np.all(k[narrowed_left] > 0)  # only on the inside of left bends
    narrowed_right = tr.width_right < tr.lane_half_right - 1e-9
    assert np.all(k[narrowed_right] < 0)
    for name in ("oval", "train-oval-small", "train-oval-large"):
        np.testing.assert_array_equal(track(name).width_left, 5.0)


def test_a_reversed_track_has_its_own_description() -> None:
    from sim_core.track_io import builtin_track_names, get_track

    for name in builtin_track_names():
        forward, backward = get_track(name), get_track(f"{name}-reversed")
        assert backward.description != forward.description
        assert backward.description.startswith("Driven the other way round")
        assert backward.reversed().description == forward.description
    assert "right-hand 90 deg corners" in get_track("oval-reversed").description


def test_lane_offsets_are_read_only_and_match_the_sample_table() -> None:
    """The per-checkpoint lane offsets are the sample table's rows at the checkpoints, and nobody can change them."""
    track = get_track("complex")
    table = track.sample_lane_offsets()
    for c in range(-1, track.n_checkpoints + 1):
        row = track.lane_offsets(c)
        assert np.array_equal(row, table[track.checkpoint_sample[c % track.n_checkpoints]])
        with pytest.raises(ValueError):
            row[0] = 0.0
