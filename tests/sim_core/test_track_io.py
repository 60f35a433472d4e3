"""Track files (sim_core.track_io): built-ins, JSON round trip, malformed files, racetrack-database CSV import."""

from __future__ import annotations

import copy
import json
import math
import pickle
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sim_core.track import Track
from sim_core.track_io import (
    FORMAT_VERSION,
    TrackFormatError,
    builtin_track_names,
    get_track,
    import_centreline_csv,
    load_track,
    save_track,
    track_from_dict,
    track_to_dict,
)

BUILTINS = ("complex", "oval", "train-hairpins", "train-oval-large", "train-oval-small")
ALL_NAMES = tuple(n for b in BUILTINS for n in (b, f"{b}-reversed"))
CSV_HEADER = "# x_m,y_m,w_tr_right_m,w_tr_left_m"


@cache
def track(name: str) -> Track:
    return get_track(name)


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


# --------------------------------------------------------------------------- built-in tracks
def test_builtin_track_names() -> None:
    assert builtin_track_names() == list(BUILTINS)


@pytest.mark.parametrize("name", BUILTINS)
def test_get_track_by_name(name: str) -> None:
    forward = get_track(name)
    backward = get_track(f"{name}-reversed")
    assert forward.name == name
    assert backward.name == f"{name}-reversed"
    assert backward.length == pytest.approx(forward.length, abs=1e-9)
    assert [s.left_turn for s in backward.sections if not s.is_straight] != [
        s.left_turn for s in forward.sections if not s.is_straight
    ]


def test_get_track_unknown_name() -> None:
    for name in ("no-such-track", "no-such-track-reversed", ""):
        with pytest.raises(KeyError, match="unknown track") as info:
            get_track(name)
        assert "oval" in str(info.value)


# --------------------------------------------------------------------------- JSON round trip
@pytest.mark.parametrize("name", ALL_NAMES)
def test_dict_round_trip(name: str) -> None:
    tr = track(name)
    data = json.loads(json.dumps(track_to_dict(tr)))  # must be plain JSON
    assert data["format_version"] == FORMAT_VERSION
    assert data["name"] == name
    assert (data["laps"], data["lane_change_limit"], data["width"]) == (tr.laps, tr.lane_change_limit, 10.0)
    assert "centreline" not in data
    assert_same_track(track_from_dict(data), tr)


@pytest.mark.parametrize("name", ["complex", "oval-reversed"])
def test_dict_round_trip_with_centreline(name: str) -> None:
    tr = track(name)
    data = json.loads(json.dumps(track_to_dict(tr, include_centreline=True)))
    assert len(data["centreline"]) == len(tr.centre_xy)
    back = track_from_dict(data)
    assert_same_track(back, tr, tol=0.01)
    np.testing.assert_allclose(back.lane_half_left, tr.lane_half_left, atol=1e-3)
    np.testing.assert_allclose(back.width_left, tr.width_left, atol=0.05)


@pytest.mark.parametrize("name", ALL_NAMES)
def test_save_and_load(tmp_path: Path, name: str) -> None:
    path = tmp_path / f"{name}.json"
    save_track(track(name), path)
    assert json.loads(path.read_text())["name"] == name
    assert_same_track(load_track(path), track(name))
    save_track(track(name), path, include_centreline=True)
    assert_same_track(load_track(path), track(name), tol=0.01)


def test_round_trip_preserves_optional_fields() -> None:
    data = track_to_dict(track("oval"))
    data["meta"] = {"author": "test", "n": 3}
    data["description"] = "hello"
    data["checkpoints"][5].pop("racing_lane")
    tr = track_from_dict(copy.deepcopy(data))
    assert tr.meta == {"author": "test", "n": 3}
    assert tr.description == "hello"
    assert tr.racing_lanes[5] is None and tr.racing_lanes[4] == data["checkpoints"][4]["racing_lane"]
    again = track_to_dict(tr)
    assert "racing_lane" not in again["checkpoints"][5]
    assert again["meta"] == data["meta"] and again["description"] == "hello"


def test_defaults_for_optional_fields() -> None:
    data = track_to_dict(track("train-oval-small"))
    for key in ("format_version", "width", "laps", "lane_change_limit", "lane_fractions", "description"):
        data.pop(key)
    tr = track_from_dict(data)
    assert (tr.laps, tr.lane_change_limit, tr.n_lanes, tr.nominal_width) == (3, 4, 4, 10.0)


# --------------------------------------------------------------------------- malformed JSON
@cache
def _valid_oval() -> dict[str, Any]:
    return track_to_dict(get_track("oval"))


def _keys(path: str) -> list[str | int]:
    """``checkpoints[2].road.type`` -> ["checkpoints", 2, "road", "type"]."""
    keys: list[str | int] = []
    for part in path.split("."):
        name, _, index = part.partition("[")
        keys.append(name)
        if index:
            keys.append(int(index.rstrip("]")))
    return keys


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    """Mutator setting the field at ``path`` to ``value``."""

    def mutate(data: dict[str, Any]) -> None:
        *head, last = _keys(path)
        target: Any = data
        for key in head:
            target = target[key]
        target[last] = value

    return mutate


def _delete(path: str) -> Callable[[dict[str, Any]], None]:
    """Mutator removing the field at ``path``."""

    def mutate(data: dict[str, Any]) -> None:
        *head, last = _keys(path)
        target: Any = data
        for key in head:
            target = target[key]
        del target[last]

    return mutate


def _truncate_checkpoints(data: dict[str, Any]) -> None:
    data["checkpoints"] = data["checkpoints"][:2]


CURVE = {"type": "curve", "inside_radius": 15.0, "angle_deg": 45.0, "turn": "left"}
MALFORMED = [
    # (mutation, field path in the error, words in the problem)
    (_set("checkpoints[2].road", {**CURVE, "inside_radius": -2.0}), "checkpoints[2].road.inside_radius", ">= 0"),
    (_set("checkpoints[1].road.type", "spiral"), "checkpoints[1].road.type", "must be one of"),
    (_set("checkpoints[0].heading_deg", "north"), "checkpoints[0].heading_deg", "finite number"),
    (_set("checkpoints[0].heading_deg", True), "checkpoints[0].heading_deg", "finite number"),
    (_truncate_checkpoints, "checkpoints", "at least 3"),
    (_set("checkpoints", {"a": 1}), "checkpoints", "list"),
    (_delete("checkpoints"), "checkpoints", "list"),
    (_set("lane_fractions", [0.25, 0.7, -0.25, -0.7]), "lane_fractions", "decreasing"),
    (_set("lane_fractions", [1.5, 0.25, -0.25, -0.7]), "lane_fractions", "(-1, 1)"),
    (_set("lane_fractions", []), "lane_fractions", "decreasing"),
    (_set("lane_fractions", "wide"), "lane_fractions", "decreasing"),
    (_set("checkpoints[3].racing_lane", 5), "checkpoints[3].racing_lane", "[1, 4]"),
    (_set("checkpoints[3].racing_lane", 2.0), "checkpoints[3].racing_lane", "integer"),
    (_set("checkpoints[4].road.angle_deg", 400), "checkpoints[4].road.angle_deg", "<= 360"),
    (_set("checkpoints[4].road.angle_deg", 0), "checkpoints[4].road.angle_deg", "> 0"),
    (_set("checkpoints[4].road.turn", "up"), "checkpoints[4].road.turn", "must be one of"),
    (_delete("checkpoints[4].road.inside_radius"), "checkpoints[4].road.inside_radius", "missing"),
    (_set("checkpoints[0].road.length", -10), "checkpoints[0].road.length", "> 0"),
    (_set("checkpoints[4].road.length", "long"), "checkpoints[4].road.length", "finite number"),
    (_delete("checkpoints[6].road"), "checkpoints[6].road", "missing"),
    (_set("checkpoints[6].road", [1, 2]), "checkpoints[6].road", "object"),
    (_set("checkpoints[1]", 7), "checkpoints[1]", "object"),
    (_set("checkpoints[0].centre", [1.0]), "checkpoints[0].centre", "[x, y]"),
    (_set("checkpoints[0].centre", [1.0, "2"]), "checkpoints[0].centre", "[x, y]"),
    (_delete("name"), "name", "missing"),
    (_set("name", 12), "name", "string"),
    (_set("width", -10), "width", "> 0"),
    (_set("laps", 0), "laps", "[1, 1000]"),
    (_set("lane_change_limit", "many"), "lane_change_limit", "integer"),
    (_set("format_version", 2), "format_version", "unsupported format version"),
    (_set("centreline", [[0, 0, 5, 5]] * 3), "centreline", "at least 8"),
    (_set("centreline", [[0, 0, 5, 5]] * 7 + [[0, 0, -5, 5]]), "centreline", "row 7"),
]


@pytest.mark.parametrize(("mutate", "field", "problem"), MALFORMED, ids=[f"{c[1]}:{c[2]}" for c in MALFORMED])
def test_malformed_field_names_file_and_field(
    tmp_path: Path, mutate: Callable[[dict[str, Any]], None], field: str, problem: str
) -> None:
    data = copy.deepcopy(_valid_oval())
    mutate(data)
    path = tmp_path / "broken_track.json"
    path.write_text(json.dumps(data, indent=1))
    with pytest.raises(TrackFormatError) as info:
        load_track(path)
    exc = info.value
    assert exc.path == str(path)
    assert exc.where == f"field {field}"
    assert problem in exc.problem
    message = str(exc)
    assert message.startswith(f"{path}: field {field}: ")
    assert "broken_track.json" in message and field in message
    assert isinstance(exc, ValueError)


def test_a_track_error_crosses_a_process_boundary_whole() -> None:
    # a race's worker process pickles the error back to the tournament runner: it must arrive as itself
    with pytest.raises(TrackFormatError) as info:
        load_track("no/such/track.json")
    copy_of = pickle.loads(pickle.dumps(info.value))
    assert type(copy_of) is TrackFormatError
    assert (copy_of.path, copy_of.where, copy_of.problem) == (info.value.path, info.value.where, info.value.problem)
    assert str(copy_of) == str(info.value) and copy_of.path == "no/such/track.json"


def test_malformed_root() -> None:
    with pytest.raises(TrackFormatError) as info:
        track_from_dict([1, 2, 3])
    assert info.value.where == "field <root>"
    assert info.value.path == "<memory>"
    with pytest.raises(TrackFormatError, match=r"^my\.json: field checkpoints\[0\]\.heading_deg: "):
        data = copy.deepcopy(_valid_oval())
        data["checkpoints"][0]["heading_deg"] = float("nan")
        track_from_dict(data, "my.json")


def test_invalid_json_names_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "syntax.json"
    path.write_text('{\n "name": "x",\n "laps": 3,,\n "width": 10\n}\n')
    with pytest.raises(TrackFormatError) as info:
        load_track(path)
    exc = info.value
    assert exc.path == str(path)
    assert exc.where == "line 3 column 12"
    assert "invalid JSON" in exc.problem
    assert str(exc).startswith(f"{path}: line 3 column 12: invalid JSON")


def test_empty_and_missing_files(tmp_path: Path) -> None:
    empty = tmp_path / "empty.json"
    empty.write_text("")
    with pytest.raises(TrackFormatError, match=r"empty\.json: line 1 column 1: invalid JSON"):
        load_track(empty)
    missing = tmp_path / "missing.json"
    with pytest.raises(TrackFormatError) as info:
        load_track(missing)
    assert info.value.where == "file" and "cannot read" in info.value.problem
    assert "missing.json" in str(info.value)


# --------------------------------------------------------------------------- racetrack-database CSV import
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
