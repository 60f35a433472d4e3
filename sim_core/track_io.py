"""Reading and writing tracks: the project's JSON format, the racetrack-database CSV format, and the
built-in tracks shipped in ``sim_core/tracks/``.

Every malformed file raises :class:`TrackFormatError`, which names the file, the line or field, and what
is wrong.
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from sim_core.track import DEFAULT_LANE_FRACTIONS, Checkpoint, Section, Track
from sim_core.track_builder import build_track, resample_closed

TRACKS_DIR = Path(__file__).parent / "tracks"
FORMAT_VERSION = 1


class TrackFormatError(ValueError):
    """A track file could not be read; the message names the file, the place in it and the problem."""

    def __init__(self, path: str | Path, where: str, problem: str) -> None:
        self.path = str(path)
        self.where = where
        self.problem = problem
        super().__init__(f"{self.path}: {where}: {problem}")

    def __reduce__(self) -> tuple[type[TrackFormatError], tuple[str, str, str]]:
        # pickled with its fields, not its message: a race's worker process sends the error back to the runner
        return (type(self), (self.path, self.where, self.problem))


# --------------------------------------------------------------------------- project JSON format
class _Fields:
    """Typed access to a JSON object that reports the field path on every error."""

    def __init__(self, path: str | Path, obj: Any, where: str) -> None:
        self.path, self.obj, self.where = path, obj, where
        if not isinstance(obj, dict):
            self.fail(f"expected an object, got {type(obj).__name__}")

    def fail(self, problem: str, key: str | None = None) -> None:
        where = self.where if key is None else (f"{self.where}.{key}" if self.where else key)
        raise TrackFormatError(self.path, f"field {where or '<root>'}", problem)

    def number(
        self, key: str, *, default: float | None = None, positive: bool = False, minimum: float | None = None
    ) -> float:
        if key not in self.obj:
            if default is None:
                self.fail("missing", key)
            return float(default)  # type: ignore[arg-type]
        value = self.obj[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(f"expected a finite number, got {value!r}", key)
        if positive and value <= 0:
            self.fail(f"must be > 0, got {value}", key)
        if minimum is not None and value < minimum:
            self.fail(f"must be >= {minimum}, got {value}", key)
        return float(value)

    def integer(self, key: str, *, default: int | None = None, lo: int | None = None, hi: int | None = None) -> int:
        if key not in self.obj:
            if default is None:
                self.fail("missing", key)
            return int(default)  # type: ignore[arg-type]
        value = self.obj[key]
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(f"expected an integer, got {value!r}", key)
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            self.fail(f"must be in [{lo}, {hi}], got {value}", key)
        return int(value)

    def text(self, key: str, *, default: str | None = None, choices: tuple[str, ...] | None = None) -> str:
        if key not in self.obj:
            if default is None:
                self.fail("missing", key)
            return str(default)
        value = self.obj[key]
        if not isinstance(value, str):
            self.fail(f"expected a string, got {value!r}", key)
        if choices and value not in choices:
            self.fail(f"must be one of {list(choices)}, got {value!r}", key)
        return str(value)

    def point(self, key: str) -> tuple[float, float]:
        value = self.obj.get(key)
        if (
            not isinstance(value, list)
            or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
        ):
            self.fail(f"expected [x, y] with two finite numbers, got {value!r}", key)
        return float(value[0]), float(value[1])

    def child(self, key: str) -> _Fields:
        if key not in self.obj:
            self.fail("missing", key)
        return _Fields(self.path, self.obj[key], f"{self.where}.{key}" if self.where else key)

    def items(self, key: str) -> list[Any]:
        value = self.obj.get(key)
        if not isinstance(value, list):
            self.fail(f"expected a list, got {type(value).__name__}", key)
        return list(value)  # type: ignore[arg-type]


def track_from_dict(data: Any, path: str | Path = "<memory>") -> Track:
    """Build a track from the project's JSON structure (see ``sim_core/tracks/*.json``)."""
    root = _Fields(path, data, "")
    version = root.integer("format_version", default=FORMAT_VERSION)
    if version != FORMAT_VERSION:
        root.fail(f"unsupported format version {version} (this code reads {FORMAT_VERSION})", "format_version")
    name = root.text("name")
    half_width = root.number("width", default=10.0, positive=True) / 2.0
    laps = root.integer("laps", default=3, lo=1, hi=1000)
    fractions_raw = root.obj.get("lane_fractions", list(DEFAULT_LANE_FRACTIONS))
    if (
        not isinstance(fractions_raw, list)
        or len(fractions_raw) < 1
        or not all(isinstance(f, (int, float)) and -1.0 < f < 1.0 for f in fractions_raw)
        or any(a <= b for a, b in itertools.pairwise(fractions_raw))
    ):
        root.fail("expected a list of numbers in (-1, 1), strictly decreasing (lane 1 is leftmost)", "lane_fractions")
    n_lanes = len(fractions_raw)
    lane_limit = root.integer("lane_change_limit", default=4, lo=0, hi=100)
    raw_cps = root.items("checkpoints")
    if len(raw_cps) < 3:
        root.fail(f"need at least 3 checkpoints, got {len(raw_cps)}", "checkpoints")
    checkpoints: list[Checkpoint] = []
    sections: list[Section] = []
    for i, raw in enumerate(raw_cps):
        cp = _Fields(path, raw, f"checkpoints[{i}]")
        centre = cp.point("centre")
        heading = math.radians(cp.number("heading_deg"))
        racing_lane = cp.integer("racing_lane", lo=1, hi=n_lanes) if "racing_lane" in cp.obj else None
        road = cp.child("road")
        kind = road.text("type", choices=("straight", "curve"))
        if kind == "straight":
            sections.append(Section(is_straight=True, length=road.number("length", positive=True)))
        else:
            inside = road.number("inside_radius", minimum=0.0)
            angle = road.number("angle_deg", positive=True)
            if angle > 360:
                road.fail(f"must be <= 360, got {angle}", "angle_deg")
            turn = road.text("turn", choices=("left", "right"))
            centre_radius = inside + half_width
            # "length" (centre-line length) is optional: tracks whose road is not symmetric about the centre
            # line (imported ones) need it, since it does not follow from inside_radius and the nominal width.
            length = road.number("length", default=math.radians(angle) * centre_radius, positive=True)
            sections.append(
                Section(
                    is_straight=False,
                    length=length,
                    inside_radius=inside,
                    angle_deg=angle,
                    left_turn=turn == "left",
                )
            )
        checkpoints.append(Checkpoint(centre, heading, racing_lane))
    centreline = None
    if "centreline" in root.obj:
        rows = root.items("centreline")
        if len(rows) < 8:
            root.fail(f"need at least 8 rows, got {len(rows)}", "centreline")
        for j, row in enumerate(rows):
            if (
                not isinstance(row, list)
                or len(row) != 4
                or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in row)
                or row[2] <= 0
                or row[3] <= 0
            ):
                root.fail(f"row {j}: expected [x, y, w_left > 0, w_right > 0], got {row!r}", "centreline")
        centreline = np.asarray(rows, dtype=float)
    meta = root.obj.get("meta", {})
    return build_track(
        name,
        checkpoints,
        sections,
        half_width=half_width,
        laps=laps,
        lane_change_limit=lane_limit,
        lane_fractions=tuple(float(f) for f in fractions_raw),
        centreline=centreline,
        description=root.text("description", default=""),
        meta=meta if isinstance(meta, dict) else {},
    )


def load_track(path: str | Path) -> Track:
    """Read a track in the project's JSON format."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise TrackFormatError(path, "file", f"cannot read: {exc.strerror or exc}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise TrackFormatError(path, f"line {exc.lineno} column {exc.colno}", f"invalid JSON: {exc.msg}") from None
    return track_from_dict(data, path)


def track_to_dict(track: Track, *, include_centreline: bool = False) -> dict[str, Any]:
    """The project's JSON structure for ``track`` (inverse of :func:`track_from_dict`)."""
    checkpoints = []
    for cp, sec in zip(track.checkpoints, track.sections):
        road: dict[str, Any]
        if sec.is_straight:
            road = {"type": "straight", "length": round(sec.length, 3)}
        else:
            road = {
                "type": "curve",
                "inside_radius": round(sec.inside_radius, 3),
                "angle_deg": round(sec.angle_deg, 3),
                "turn": "left" if sec.left_turn else "right",
                "length": round(sec.length, 3),
            }
        entry: dict[str, Any] = {
            "centre": [round(cp.centre[0], 4), round(cp.centre[1], 4)],
            "heading_deg": round(math.degrees(cp.heading), 4),
            "road": road,
        }
        if cp.racing_lane is not None:
            entry["racing_lane"] = cp.racing_lane
        checkpoints.append(entry)
    out: dict[str, Any] = {
        "format_version": FORMAT_VERSION,
        "name": track.name,
        "description": track.description,
        "width": round(track.nominal_width, 4),
        "laps": track.laps,
        "lane_change_limit": track.lane_change_limit,
        "lane_fractions": list(track.lane_fractions),
        "checkpoints": checkpoints,
    }
    if include_centreline:
        out["centreline"] = [
            [round(float(x), 4), round(float(y), 4), round(float(wl), 4), round(float(wr), 4)]
            for (x, y), wl, wr in zip(track.centre_xy, track.lane_half_left, track.lane_half_right)
        ]
    if track.meta:
        out["meta"] = track.meta
    return out


def save_track(track: Track, path: str | Path, *, include_centreline: bool = False) -> None:
    """Write ``track`` in the project's JSON format."""
    Path(path).write_text(json.dumps(track_to_dict(track, include_centreline=include_centreline), indent=1) + "\n")


# --------------------------------------------------------------------------- built-in tracks
def builtin_track_names() -> list[str]:
    """Names of the tracks shipped with the project (each also available as ``NAME-reversed``)."""
    return sorted(p.stem for p in TRACKS_DIR.glob("*.json"))


def get_track(name: str) -> Track:
    """A built-in track by name; ``NAME-reversed`` gives it driven the other way."""
    base = name[: -len("-reversed")] if name.endswith("-reversed") else name
    path = TRACKS_DIR / f"{base}.json"
    if not path.exists():
        raise KeyError(f"unknown track {name!r}; known: {builtin_track_names()} (each also as NAME-reversed)")
    track = load_track(path)
    return track.reversed() if base != name else track


# --------------------------------------------------------------------------- racetrack-database CSV
def import_centreline_csv(
    path: str | Path,
    *,
    name: str | None = None,
    scale: float = 1.0,
    width_scale: float | None = None,
    checkpoint_spacing: float = 10.0,
    straight_min_radius: float = 60.0,
    laps: int = 3,
    lane_change_limit: int = 4,
) -> Track:
    """Import a closed circuit in the racetrack-database CSV format (``x_m,y_m,w_tr_right_m,w_tr_left_m``).

    Coordinates are multiplied by ``scale``, widths by ``width_scale`` (default ``scale``: a circuit shrunk to kart
    size is otherwise narrower than a kart track; 0.6 gives a 15 m wide circuit 9 m). Checkpoints are placed about every
    ``checkpoint_spacing`` metres; a section is a straight when its mean radius of curvature exceeds
    ``straight_min_radius`` metres, otherwise a curve whose radius, angle and direction come from the
    heading change along it.
    """
    path = Path(path)
    if scale <= 0 or not math.isfinite(scale):
        raise ValueError(f"scale must be a positive number, got {scale}")
    widths = scale if width_scale is None else width_scale
    if widths <= 0 or not math.isfinite(widths):
        raise ValueError(f"width_scale must be a positive number, got {width_scale}")
    data = _read_centreline_rows(path, scale)
    data[:, 2:] *= widths / scale
    # Light circular smoothing of the centre line: measured centre lines are noisy at the 0.1 m level,
    # and the headings and curvature used to classify sections come from its derivatives.
    xy, s, length = resample_closed(data[:, :2], 0.5)
    kernel = np.ones(9) / 9.0
    smooth = np.stack([_circular_convolve(xy[:, 0], kernel), _circular_convolve(xy[:, 1], kernel)], axis=1)
    closed = np.vstack([data[:, :2], data[:1, :2]])
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    wl = np.interp(s * cum[-1] / length, cum, np.append(data[:, 2], data[0, 2]))
    wr = np.interp(s * cum[-1] / length, cum, np.append(data[:, 3], data[0, 3]))
    tangent = np.roll(smooth, -1, axis=0) - np.roll(smooth, 1, axis=0)
    heading = np.unwrap(np.arctan2(tangent[:, 1], tangent[:, 0]))
    n_cp = max(round(length / checkpoint_spacing), 4)
    idx = np.round(np.linspace(0, len(smooth), n_cp, endpoint=False)).astype(int)
    checkpoints: list[Checkpoint] = []
    sections: list[Section] = []
    total_turn = heading[-1] - heading[0] + np.angle(np.exp(1j * (heading[0] - heading[-1])))
    for k, i in enumerate(idx):
        j = idx[(k + 1) % n_cp]
        turn = (heading[j] - heading[i]) if j > i else (heading[j] + total_turn - heading[i])
        seg_len = ((j - i) % len(smooth) or len(smooth)) * (length / len(smooth))
        mean_radius = seg_len / max(abs(turn), 1e-9)
        checkpoints.append(Checkpoint((float(smooth[i, 0]), float(smooth[i, 1])), float(heading[i] % (2 * np.pi))))
        if mean_radius > straight_min_radius:
            sections.append(Section(is_straight=True, length=float(seg_len)))
        else:
            inside_w = wl[i] if turn > 0 else wr[i]
            sections.append(
                Section(
                    is_straight=False,
                    length=float(seg_len),
                    inside_radius=float(max(mean_radius - inside_w, 0.0)),
                    angle_deg=float(math.degrees(abs(turn))),
                    left_turn=bool(turn > 0),
                )
            )
    centreline = np.column_stack([smooth, wl, wr])
    return build_track(
        name or path.stem,
        checkpoints,
        sections,
        laps=laps,
        lane_change_limit=lane_change_limit,
        centreline=centreline,
        description=f"imported from {path.name} (scale {scale})",
        meta={"source": str(path.name), "scale": scale},
    )


def _read_centreline_rows(path: Path, scale: float) -> np.ndarray:
    """The rows ``x, y, w_left, w_right`` (scaled) of a racetrack-database CSV, without a repeated closing row;
    raises :class:`TrackFormatError` naming the first bad line (or the file, when it is unreadable or short)."""
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise TrackFormatError(path, "file", f"cannot read: {exc.strerror or exc}") from None
    rows: list[tuple[float, float, float, float]] = []
    row_lines: list[int] = []  # file line number of each row
    first_content_line = True
    for lineno, line in enumerate(lines, start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        parts = [p.strip() for p in stripped.split(",")]
        # Only the first non-comment line may be a header without '#', and only if none of it is a number
        # (a damaged first data row must be reported, not silently dropped).
        if first_content_line and not any(_is_number(p) for p in parts):
            first_content_line = False
            continue
        first_content_line = False
        if len(parts) != 4:
            raise TrackFormatError(path, f"line {lineno}", f"expected 4 comma-separated fields, got {len(parts)}")
        try:
            values = tuple(float(p) for p in parts)
        except ValueError:
            raise TrackFormatError(path, f"line {lineno}", f"not a number in {stripped!r}") from None
        if not all(math.isfinite(v) for v in values):
            raise TrackFormatError(path, f"line {lineno}", "values must be finite")
        x, y, w_right, w_left = values
        if w_right <= 0 or w_left <= 0:
            raise TrackFormatError(
                path, f"line {lineno}", f"track widths must be > 0, got right={w_right}, left={w_left}"
            )
        rows.append((x * scale, y * scale, w_left * scale, w_right * scale))
        row_lines.append(lineno)
    if len(rows) < 8:
        raise TrackFormatError(path, "file", f"need at least 8 centre-line rows, got {len(rows)}")
    data = np.asarray(rows)
    if np.linalg.norm(data[0, :2] - data[-1, :2]) < 1e-6:
        data = data[:-1]
    steps = np.linalg.norm(np.diff(np.vstack([data[:, :2], data[:1, :2]]), axis=0), axis=1)
    if np.any(steps < 1e-9):
        bad = int(np.argmin(steps))
        raise TrackFormatError(path, f"line {row_lines[(bad + 1) % len(data)]}", "repeated point in the centre line")
    return data


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _circular_convolve(values: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    pad = len(kernel) // 2
    wrapped = np.concatenate([values[-pad:], values, values[:pad]])
    return np.convolve(wrapped, kernel, mode="valid")
