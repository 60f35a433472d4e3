"""Track files (sim_core.track_io): built-ins, JSON round trip, malformed files (the racetrack-database CSV import:
``test_track_import_csv.py``)."""

from __future__ import annotations

import copy
import json
import pickle
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from support.track_geometry import assert_same_track

from sim_core.track import Track
from sim_core.track_io import (
    FORMAT_VERSION,
    TrackFormatError,
    builtin_track_names,
    get_track,
    load_track,
    save_track,
    track_from_dict,
    track_to_dict,
)

BUILTINS = (
    "brands-hatch",
    "complex",
    "norisring",
    "oval",
    "train-hairpins",
    "train-narrow-hairpins",
    "train-oval-large",
    "train-oval-small",
)
ALL_NAMES = tuple(n for b in BUILTINS for n in (b, f"{b}-reversed"))
CSV_HEADER = "# x_m,y_m,w_tr_right_m,w_tr_left_m"


@cache
def track(name: str) -> Track:
    return get_track(name)


# --------------------------------------------------------------------------- built-in tracks
def test_builtin_track_names() -> None:
    assert builtin_track_names() == list(BUILTINS)


@pytest.mark.parametrize("name", BUILTINS)
def test_get_track_by_name(name: str) -> None:
    forward = get_track(name)
    backward = get_track(f"{name}-reversed")
    assert forward.name == name
    assert backward.name == f"{name}-reversed"
    assert backward.length == pytest.approx(forward.length, abs=1e-6)
    assert [s.left_turn for s in backward.sections if not s.is_straight] != [
        s.left_turn for s in forward.sections if not s.is_straight
    ]


def test_get_track_unknown_name() -> None:
    for name in ("no-such-track", "no-such-track-reversed", ""):
        with pytest.raises(KeyError, match="unknown track") as info:
            get_track(name)
        assert "oval" in str(info.value)


# --------------------------------------------------------------------------- JSON round trip
# imported circuits: their centre line does not follow from the sections, so their files carry it
IMPORTED = {"brands-hatch", "brands-hatch-reversed", "norisring", "norisring-reversed"}


@pytest.mark.parametrize("name", ALL_NAMES)
def test_dict_round_trip(name: str) -> None:
    tr = track(name)
    imported = name in IMPORTED
    data = json.loads(json.dumps(track_to_dict(tr, include_centreline=imported)))  # must be plain JSON
    assert data["format_version"] == FORMAT_VERSION
    assert data["name"] == name
    assert (data["laps"], data["lane_change_limit"], data["width"]) == (tr.laps, tr.lane_change_limit, tr.nominal_width)
    assert ("centreline" in data) == imported
    assert_same_track(track_from_dict(data), tr, tol=0.01 if imported else 1e-6)


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
    if name not in IMPORTED:
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
