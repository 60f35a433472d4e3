"""Importing a racetrack-database centre line (CSV, ``sim_core.track_io.import_centreline_csv``): straights and
bends of a drawn stadium become sections, widths and walls follow the file, options and header variants are read,
an imported track round-trips through JSON and reverses, and every malformed file is named by line."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from support.track_geometry import assert_same_track

from sim_core.track import Track
from sim_core.track_io import TrackFormatError, import_centreline_csv, load_track, save_track

CSV_HEADER = "# x_m,y_m,w_tr_right_m,w_tr_left_m"


def stadium(straight: float = 100.0, radius: float = 30.0, step: float = 2.0, ccw: bool = True) -> np.ndarray:
    """Closed stadium centre line: bottom straight heading +x from the origin, then counter-clockwise."""
    n = round(straight / step)
    m = round(math.pi * radius / step)
    line = [(i * straight / n, 0.0) for i in range(n)]
    line += [
        (straight + radius * math.sin(math.pi * i / m), radius - radius * math.cos(math.pi * i / m)) for i in range(m)
    ]
    line += [(straight - i * straight / n, 2 * radius) for i in range(n)]
    line += [(-radius * math.sin(math.pi * i / m), radius + radius * math.cos(math.pi * i / m)) for i in range(m)]
    points = np.array(line)
    return points if ccw else points[::-1].copy()


def csv_lines(points: np.ndarray, w_right: float = 6.0, w_left: float = 6.0) -> list[str]:
    return [CSV_HEADER] + [f"{x:.4f},{y:.4f},{w_right},{w_left}" for x, y in points]


def write_csv(path: Path, lines: list[str]) -> Path:
    path.write_text("\n".join(lines) + "\n")
    return path


def classify(tr: Track, scale: float, straight: float = 100.0, radius: float = 30.0) -> tuple[list[int], list[int]]:
    """Sections lying wholly on a straight / wholly on a semicircle of the scaled stadium (2 m margins)."""
    length, r = straight * scale, radius * scale

    def on_straight(p: tuple[float, float]) -> bool:
        return 2.0 <= p[0] <= length - 2.0 and min(abs(p[1]), abs(p[1] - 2 * r)) < 0.3

    def on_arc(p: tuple[float, float]) -> bool:
        centre = (length, r) if p[0] > length else (0.0, r)
        return (p[0] >= length + 2.0 or p[0] <= -2.0) and abs(math.dist(p, centre) - r) < 0.3

    straights, curves = [], []
    for c in range(tr.n_checkpoints):
        a, b = tr.checkpoints[c].centre, tr.checkpoints[(c + 1) % tr.n_checkpoints].centre
        if on_straight(a) and on_straight(b):
            straights.append(c)
        elif on_arc(a) and on_arc(b):
            curves.append(c)
    return straights, curves


def check_walls(tr: Track) -> None:
    """Inner walls inside the local radius of curvature, and every wall sample at its width from the centre."""
    k = tr.centre_curvature
    for width, side, wall in ((tr.width_left, 1.0, tr.left_wall), (tr.width_right, -1.0, tr.right_wall)):
        inner = side * k > 0
        assert np.all(width[inner] * np.abs(k[inner]) < 1.0)
        for i in range(0, len(wall), 2):
            d = tr.project(wall[i])[1]
            assert abs(d - side * width[i]) < 0.05, f"wall sample {i}: d={d:.3f}, width={width[i]:.3f}"


def test_import_stadium(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "stadium.csv", csv_lines(stadium()))
    tr = import_centreline_csv(path, scale=0.5)
    perimeter = 0.5 * (2 * 100.0 + 2 * math.pi * 30.0)
    assert tr.length == pytest.approx(perimeter, rel=0.02)
    assert tr.name == "stadium"
    assert tr.meta["scale"] == 0.5 and "stadium.csv" in tr.description
    assert (tr.laps, tr.lane_change_limit, tr.n_lanes) == (3, 4, 4)
    assert tr.n_checkpoints == round(tr.length / 10.0)
    spacing = np.diff(np.append(tr.checkpoint_s, tr.length + tr.checkpoint_s[0]))
    assert np.all(np.abs(spacing - 10.0) < 1.5), spacing
    # checkpoint centres lie on the centre line
    for c, cp in enumerate(tr.checkpoints):
        s, d = tr.project(np.array(cp.centre))
        assert abs(d) < 0.01 and abs(s - tr.checkpoint_s[c]) < 0.01
    straights, curves = classify(tr, 0.5)
    assert len(straights) >= 5 and len(curves) >= 4
    for c in straights:
        assert tr.sections[c].is_straight, f"section {c} on a straight"
    for c in curves:
        sec = tr.sections[c]
        assert not sec.is_straight and sec.left_turn, f"section {c} on a semicircle"
        assert sec.inside_radius == pytest.approx(0.5 * 30 - 0.5 * 6, rel=0.2)
        assert sec.angle_deg == pytest.approx(math.degrees(sec.length / 15.0), rel=0.2)
    # widths are scaled: 6 m each side -> 3 m; a 15 m bend is wide enough not to narrow them
    np.testing.assert_allclose(tr.lane_half_left, 3.0)
    np.testing.assert_allclose(tr.lane_half_right, 3.0)
    np.testing.assert_allclose(tr.width_left, 3.0)
    np.testing.assert_allclose(tr.width_right, 3.0)
    assert tr.nominal_width == pytest.approx(6.0)
    check_walls(tr)


def test_import_clockwise_stadium_turns_right(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "cw.csv", csv_lines(stadium(ccw=False), w_right=2.0, w_left=6.0))
    tr = import_centreline_csv(path, scale=0.5)
    straights, curves = classify(tr, 0.5)
    assert len(straights) >= 5 and len(curves) >= 4
    assert all(tr.sections[c].is_straight for c in straights)
    for c in curves:
        sec = tr.sections[c]
        assert not sec.is_straight and not sec.left_turn
        assert sec.inside_radius == pytest.approx(15.0 - 1.0, rel=0.05)  # inside = right side, 2 m * 0.5
    total = sum(s.angle_deg * (1 if s.left_turn else -1) for s in tr.sections if not s.is_straight)
    assert total == pytest.approx(-360.0, abs=15.0)


def test_import_reads_right_then_left_width(tmp_path: Path) -> None:
    """Columns are x, y, w_tr_right, w_tr_left."""
    path = write_csv(tmp_path / "asym.csv", csv_lines(stadium(), w_right=4.0, w_left=8.0))
    tr = import_centreline_csv(path, scale=0.5)
    np.testing.assert_allclose(tr.lane_half_left, 4.0)
    np.testing.assert_allclose(tr.lane_half_right, 2.0)
    d = tr.project(tr.left_wall[0])[1]
    assert d == pytest.approx(4.0, abs=0.01)
    _, curves = classify(tr, 0.5)
    for c in curves:
        assert tr.sections[c].inside_radius == pytest.approx(15.0 - 4.0, rel=0.05)  # left turn: inside = left


def test_import_header_variants(tmp_path: Path) -> None:
    lines = csv_lines(stadium())
    reference = import_centreline_csv(write_csv(tmp_path / "a.csv", lines), scale=0.5)
    variants = {
        "plain_header": ["x_m,y_m,w_tr_right_m,w_tr_left_m", *lines[1:]],
        "both_headers": [lines[0], "x_m, y_m, w_tr_right_m, w_tr_left_m", *lines[1:]],
        "no_header": lines[1:],
        "blank_lines_and_spaces": ["", lines[0], "", *(line.replace(",", " , ") for line in lines[1:]), ""],
        "closing_row": [*lines, lines[1]],
    }
    for name, variant in variants.items():
        tr = import_centreline_csv(write_csv(tmp_path / f"{name}.csv", variant), scale=0.5)
        assert tr.name == name
        assert tr.length == pytest.approx(reference.length, abs=1e-6), name
        assert tr.n_checkpoints == reference.n_checkpoints, name
        np.testing.assert_allclose(tr.centre_xy, reference.centre_xy, atol=1e-6, err_msg=name)


def test_import_options(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "s.csv", csv_lines(stadium()))
    tr = import_centreline_csv(path, name="mine", scale=1.0, checkpoint_spacing=20.0, laps=5, lane_change_limit=2)
    assert (tr.name, tr.laps, tr.lane_change_limit) == ("mine", 5, 2)
    assert tr.length == pytest.approx(2 * 100.0 + 2 * math.pi * 30.0, rel=0.02)
    assert tr.n_checkpoints == round(tr.length / 20.0)
    np.testing.assert_allclose(tr.lane_half_left, 6.0)
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="scale"):
            import_centreline_csv(path, scale=bad)


def test_imported_tight_bend_narrows_inner_wall(tmp_path: Path) -> None:
    """6.5 m radius bends on a road 6 m wide each side: the inner wall (6 m > 0.85 * 6.5 m) is pulled in so it
    stays inside the radius of curvature; the outside keeps its width. (The straights are 13 m apart, so
    the road does not overlap itself.)"""
    path = write_csv(tmp_path / "tight.csv", csv_lines(stadium(straight=60.0, radius=6.5, step=0.5)))
    tr = import_centreline_csv(path, scale=1.0)
    assert tr.width_left.min() < 0.86 * 6.5  # narrowed on the inside of the (left) bends
    np.testing.assert_allclose(tr.width_right, 6.0)
    np.testing.assert_allclose(tr.lane_half_left, 6.0)  # lanes keep their nominal place
    check_walls(tr)
    check_walls(tr.reversed())


def test_imported_track_round_trip_and_reverse(tmp_path: Path) -> None:
    tr = import_centreline_csv(write_csv(tmp_path / "rt.csv", csv_lines(stadium(), 4.0, 8.0)), scale=0.5)
    path = tmp_path / "rt.json"
    save_track(tr, path, include_centreline=True)
    back = load_track(path)
    assert_same_track(back, tr, tol=0.01)
    np.testing.assert_allclose(back.lane_half_left, tr.lane_half_left, atol=1e-3)
    np.testing.assert_allclose(back.lane_half_right, tr.lane_half_right, atol=1e-3)
    assert back.meta == tr.meta
    rev = tr.reversed()
    np.testing.assert_allclose(rev.lane_half_left, 2.0)  # the old right side is now on the left
    np.testing.assert_allclose(rev.lane_half_right, 4.0)
    assert rev.length == pytest.approx(tr.length, abs=1e-9)
    np.testing.assert_allclose(rev.reversed().centre_s, tr.centre_s, atol=1e-9)


def _with(line_no: int, text: str | None) -> Callable[[list[str]], list[str]]:
    """Replace (or, with None, delete) 1-based line ``line_no`` of the file."""

    def edit(lines: list[str]) -> list[str]:
        out = list(lines)
        if text is None:
            del out[line_no - 1]
        else:
            out[line_no - 1] = text
        return out

    return edit


MALFORMED_CSV = [
    # (edit, where, words in the problem)
    (_with(6, "1.0,abc,6,6"), "line 6", "not a number"),
    (_with(2, "1.0,abc,6,6"), "line 2", "not a number"),  # a damaged first row is not a header
    (_with(40, "1.0,2.0,6"), "line 40", "got 3"),
    (_with(2, "1.0,2.0,6,6,7"), "line 2", "got 5"),
    (_with(7, "1.0,2.0,6,-1"), "line 7", "> 0"),
    (_with(7, "1.0,2.0,0,6"), "line 7", "> 0"),
    (_with(9, "1.0,nan,6,6"), "line 9", "finite"),
    (_with(9, "inf,1.0,6,6"), "line 9", "finite"),
    (_with(12, "x,y,w_right,w_left"), "line 12", "not a number"),  # a header after the data has started
    (lambda lines: [*lines[:1], *(f"{line}," for line in lines[1:])], "line 2", "got 5"),
    (lambda lines: lines[:8], "file", "at least 8"),  # header + 7 rows
    (lambda lines: [lines[0]], "file", "got 0"),
    (lambda lines: [*lines[:6], lines[5], *lines[6:]], "line 7", "repeated point"),
]


@pytest.mark.parametrize(("edit", "where", "problem"), MALFORMED_CSV, ids=[f"{c[1]}:{c[2]}" for c in MALFORMED_CSV])
def test_malformed_csv(tmp_path: Path, edit: Callable[[list[str]], list[str]], where: str, problem: str) -> None:
    path = write_csv(tmp_path / "broken_centreline.csv", edit(csv_lines(stadium())))
    with pytest.raises(TrackFormatError) as info:
        import_centreline_csv(path, scale=0.5)
    exc = info.value
    assert exc.path == str(path)
    assert exc.where == where
    assert problem in exc.problem
    assert str(exc).startswith(f"{path}: {where}: ")


def test_missing_csv(tmp_path: Path) -> None:
    with pytest.raises(TrackFormatError) as info:
        import_centreline_csv(tmp_path / "nowhere.csv")
    assert info.value.where == "file" and "nowhere.csv" in str(info.value)
