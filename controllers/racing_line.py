"""The offline racing line of the Fixed agents: a minimum-curvature line found by a QP (OSQP), a speed profile
from the kart's limits, and the lane per checkpoint that the Fixed agents and the planner's rollouts use.

Minimum curvature: the line is the centre line shifted by ``alpha_i`` along the normal at each of M samples
(1 m apart); its curvature is approximated by second differences, so the sum of squared curvatures is a
convex quadratic in ``alpha`` with box constraints (keep ``margin`` inside the walls). The speed profile is
the usual forward (acceleration) / backward (braking) pass under the cornering speed of every point.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import osqp
import scipy.sparse as sp
from scipy.interpolate import CubicSpline

from sim_core.params import KartParams
from sim_core.track import Track

LINE_SPACING = 1.0  # [m] sample spacing of the optimised line
ValueSlopes = tuple[list[float], list[float]]  # values at the samples, and each segment's slope


@dataclass(frozen=True)
class RacingLine:
    """A closed line around the track with its speed profile."""

    s: np.ndarray  # (M,) [m] centre-line progress of each sample
    offset: np.ndarray  # (M,) [m] left-positive lateral offset from the centre line
    xy: np.ndarray  # (M, 2) [m] world positions
    speed: np.ndarray  # (M,) [m/s] speed profile
    lap_time: float  # [s] predicted lap time of the speed profile
    checkpoint_lanes: tuple[int, ...]  # lane (1-based) nearest to the line at each checkpoint

    @cached_property
    def _closed(self) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        # the samples with the first one repeated one lap on: np.interp's period= re-sorts on every call
        length = float(self.s[-1] + (self.s[1] - self.s[0]))
        return (
            length,
            np.append(self.s, self.s[0] + length),
            np.append(self.offset, self.offset[0]),
            np.append(self.speed, self.speed[0]),
        )

    @property
    def closed_length(self) -> float:
        """[m] the lap of the line's samples (one sample spacing past the last): its lookups wrap at this."""
        return self._closed[0]

    @property
    def interpolation_tables(
        self,
    ) -> tuple[list[float], tuple[list[float], list[float]], tuple[list[float], list[float]]]:
        """The one-point lookups' tables: the closed samples' progress, and (values, slopes) of the offset and of
        the speed profile (what :func:`_interp_at` reads; compiled code reads the same numbers)."""
        return self._sample_s, self._offset_table, self._speed_table

    @property
    def closed_s(self) -> np.ndarray:
        """(M + 1,) [m] the samples' centre-line progress with the first repeated one lap on (its last entry is
        the lap length)."""
        return self._closed[1]

    def offset_at(self, s: float | np.ndarray) -> float | np.ndarray:
        """Lateral offset [m] of the line at centre-line progress ``s`` (periodic interpolation)."""
        length, s_closed, offset_closed, _ = self._closed
        if isinstance(s, float):
            return _interp_at(s % length, self._sample_s, *self._offset_table)
        return np.interp(np.mod(s, length), s_closed, offset_closed)

    def speed_at(self, s: float | np.ndarray) -> float | np.ndarray:
        """Speed [m/s] of the line's profile at centre-line progress ``s`` (periodic interpolation)."""
        length, s_closed, _, speed_closed = self._closed
        if isinstance(s, float):
            return _interp_at(s % length, self._sample_s, *self._speed_table)
        return np.interp(np.mod(s, length), s_closed, speed_closed)

    # the LQ trackers look the line up a few times per kart and step, one point at a time, where np.interp's call
    # costs more than the arithmetic: the closed samples as floats, and each segment's slope computed as np.interp
    # computes it, so that a point gets the very same number
    @cached_property
    def _sample_s(self) -> list[float]:
        return [float(v) for v in self._closed[1]]

    @cached_property
    def _offset_table(self) -> tuple[list[float], list[float]]:
        return _slopes(self._sample_s, self._closed[2])

    @cached_property
    def _speed_table(self) -> tuple[list[float], list[float]]:
        return _slopes(self._sample_s, self._closed[3])


def _slopes(xs: list[float], values: np.ndarray) -> tuple[list[float], list[float]]:
    """``values`` as floats, and the slope of each segment between ``xs``."""
    ys = [float(v) for v in values]
    return ys, [(ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i]) for i in range(len(xs) - 1)]


def _interp_at(x: float, xs: list[float], ys: list[float], slopes: list[float]) -> float:
    """np.interp(x, xs, ys) for one point, as numpy computes it (``slopes`` from :func:`_slopes`)."""
    j = bisect.bisect_right(xs, x) - 1
    if j < 0:
        return ys[0]
    if j >= len(xs) - 1 or xs[j] == x:
        return ys[j]
    return slopes[j] * (x - xs[j]) + ys[j]


def _centre_samples(track: Track, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    m = max(round(track.length / spacing), 16)
    s = np.linspace(0.0, track.length, m, endpoint=False)
    period = track.length
    x = np.interp(s, track.centre_s, track.centre_xy[:, 0], period=period)
    y = np.interp(s, track.centre_s, track.centre_xy[:, 1], period=period)
    nx = np.interp(s, track.centre_s, track.centre_normal[:, 0], period=period)
    ny = np.interp(s, track.centre_s, track.centre_normal[:, 1], period=period)
    norm = np.hypot(nx, ny)
    wl = np.interp(s, track.centre_s, track.width_left, period=period)
    wr = np.interp(s, track.centre_s, track.width_right, period=period)
    return s, np.stack([x, y], axis=1), np.stack([nx / norm, ny / norm], axis=1), wl, wr


LineTerms = list[tuple[sp.csc_matrix, np.ndarray]]


def _line_qp(
    track: Track, margin: float, spacing: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, LineTerms, np.ndarray, np.ndarray]:
    """The pieces of the line QPs: samples, curvature and length Hessians and linear terms, and bounds."""
    s, xy, normal, wl, wr = _centre_samples(track, spacing)
    m = len(s)
    second = sp.diags([np.ones(m), -2 * np.ones(m), np.ones(m)], [-1, 0, 1], shape=(m, m), format="lil")
    second[0, m - 1] = 1.0
    second[m - 1, 0] = 1.0
    first = sp.diags([-np.ones(m), np.ones(m)], [0, 1], shape=(m, m), format="lil")
    first[m - 1, 0] = 1.0
    terms = []
    for diff in (second.tocsc(), first.tocsc()):
        ax = diff @ sp.diags(normal[:, 0])
        ay = diff @ sp.diags(normal[:, 1])
        terms.append(((ax.T @ ax + ay.T @ ay).tocsc(), ax.T @ (diff @ xy[:, 0]) + ay.T @ (diff @ xy[:, 1])))
    lower = -(wr - margin)
    upper = wl - margin
    if np.any(lower > upper):
        raise ValueError(f"track {track.name!r} is narrower than twice the margin {margin} m somewhere")
    return s, xy, normal, terms, lower, upper


def _solve_box_qp(hessian: sp.csc_matrix, linear: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    m = len(linear)
    solver = osqp.OSQP()
    solver.setup(
        P=sp.triu(hessian, format="csc"),
        q=linear,
        A=sp.identity(m, format="csc"),
        l=lower,
        u=upper,
        verbose=False,
        eps_abs=1e-7,
        eps_rel=1e-7,
        max_iter=20000,
        polishing=False,
    )
    result = solver.solve(raise_error=False)
    if result.x is None or result.info.status not in ("solved", "solved inaccurate"):
        raise RuntimeError(f"racing-line QP failed: {result.info.status}")
    return np.clip(result.x, lower, upper)


def minimum_curvature_offsets(
    track: Track, margin: float, spacing: float = LINE_SPACING
) -> tuple[np.ndarray, np.ndarray]:
    """(s, alpha): centre-line progress and the offsets of the minimum-curvature line (solved with OSQP)."""
    s, _, _, ((h_curv, q_curv), _), lower, upper = _line_qp(track, margin, spacing)
    return s, _solve_box_qp(h_curv, q_curv, lower, upper)


def brake_sweep(v: np.ndarray, ds: np.ndarray, decel: float) -> None:
    """One backward pass round a closed line, in place: no speed ``v[i]`` [m/s] faster than braking at ``decel``
    [m/s^2] over ``ds[i]`` [m] (from sample i to i + 1) reaches the next sample's."""
    m = len(v)
    for i in range(m - 1, -1, -1):
        j = (i + 1) % m
        v[i] = min(v[i], np.sqrt(v[j] ** 2 + 2.0 * decel * ds[i]))


def speed_profile(xy: np.ndarray, kart: KartParams, wear: float) -> tuple[np.ndarray, float]:
    """(speed at each point, lap time) of a closed line under the kart's limits at tyre wear ``wear``."""
    nxt = np.roll(xy, -1, axis=0)
    prv = np.roll(xy, 1, axis=0)
    a = np.linalg.norm(xy - prv, axis=1)
    b = np.linalg.norm(nxt - xy, axis=1)
    c = np.linalg.norm(nxt - prv, axis=1)
    cross = (xy[:, 0] - prv[:, 0]) * (nxt[:, 1] - prv[:, 1]) - (xy[:, 1] - prv[:, 1]) * (nxt[:, 0] - prv[:, 0])
    curvature = 2.0 * np.abs(cross) / np.maximum(a * b * c, 1e-12)  # circle through three points
    a_lat = float(kart.lateral_limit(wear))
    v_max = np.minimum(kart.top_speed, np.sqrt(a_lat / np.maximum(curvature, 1e-9)))
    ds = b  # distance from point i to i+1
    v = v_max.copy()
    m = len(v)
    for _ in range(2):  # twice round the loop settles the periodic boundary
        for i in range(m):
            j = (i + 1) % m
            v[j] = min(v[j], np.sqrt(v[i] ** 2 + 2.0 * kart.acceleration * ds[i]))
        brake_sweep(v, ds, kart.braking)
    lap_time = float(np.sum(2.0 * ds / (v + np.roll(v, -1))))
    return v, lap_time


def _lanes_at_checkpoints(track: Track, s: np.ndarray, offset: np.ndarray) -> tuple[int, ...]:
    lanes = []
    for c in range(track.n_checkpoints):
        d = float(np.interp(track.checkpoint_s[c], s, offset, period=track.length))
        lanes.append(track.lane_id(c, d))
    return tuple(lanes)


# weights of path length against curvature tried by the optimiser, relative to the ratio of the two Hessians
LENGTH_WEIGHTS = (0.0, 1e-3, 3e-3, 1e-2, 3e-2, 1e-1)


_LINES: dict[tuple[object, ...], RacingLine] = {}


def optimise_racing_line(track: Track, kart: KartParams, *, wear: float = 0.25, margin: float = 1.0) -> RacingLine:
    """:func:`compute_racing_line`, cached per track, kart, wear and margin: a hierarchical driver's planner and
    tracker both need the line."""
    key = (track.name, float(track.length), track.n_checkpoints, float(track.checkpoint_s.sum()), kart, wear, margin)
    cached = _LINES.get(key)
    if cached is None:
        cached = _LINES[key] = compute_racing_line(track, kart, wear=wear, margin=margin)
    return cached


def compute_racing_line(track: Track, kart: KartParams, *, wear: float = 0.25, margin: float = 1.0) -> RacingLine:
    """The fastest of a family of QP lines kept ``margin`` m inside the walls, with its speed profile (no cache).

    Each line minimises squared curvature plus a weight times squared segment length (curvature matters
    where the kart is grip-limited, length where it is not); the weight is chosen by the lap time of the
    speed profile. Weight 0 is the pure minimum-curvature line.
    """
    s, centre, normal, ((h_curv, q_curv), (h_len, q_len)), lower, upper = _line_qp(track, margin, LINE_SPACING)
    scale = h_curv.diagonal().sum() / h_len.diagonal().sum()
    best: RacingLine | None = None
    for weight in LENGTH_WEIGHTS:
        offset = _solve_box_qp(h_curv + weight * scale * h_len, q_curv + weight * scale * q_len, lower, upper)
        xy = centre + normal * offset[:, None]
        speed, lap_time = speed_profile(xy, kart, wear)
        if best is None or lap_time < best.lap_time:
            best = RacingLine(s, offset, xy, speed, lap_time, _lanes_at_checkpoints(track, s, offset))
    assert best is not None
    return best


def handset_line(track: Track, kart: KartParams, *, wear: float = 0.25) -> RacingLine:
    """The original's hand-set lanes as a line through the racing lane at each checkpoint (a periodic cubic
    spline of the lateral offset, so it is as smooth as a kart can drive it).

    ``racing_lanes[i]`` is the lane aimed for at checkpoint i + 1 (the original's ``optimalLane`` semantics).
    """
    lanes = track.racing_lanes
    if any(lane is None for lane in lanes):
        raise ValueError(f"track {track.name!r} has no hand-set racing lanes")
    n = track.n_checkpoints
    at_checkpoint = [int(lanes[(c - 1) % n]) for c in range(n)]  # type: ignore[arg-type]
    knots_s = np.asarray(track.checkpoint_s)
    knots_d = np.array([track.lane_offsets(c)[at_checkpoint[c] - 1] for c in range(n)])
    s, centre, normal, _, _ = _centre_samples(track, LINE_SPACING)
    spline = CubicSpline(np.append(knots_s, track.length), np.append(knots_d, knots_d[0]), bc_type="periodic")
    offset = spline(s)
    xy = centre + normal * offset[:, None]
    speed, lap_time = speed_profile(xy, kart, wear)
    return RacingLine(s, offset, xy, speed, lap_time, tuple(at_checkpoint))


SHIFT_STEP = 0.25  # [m] grid of the sideways shifts of the line whose speed profiles are computed
WALL_CLEARANCE = 1.0  # [m] a shifted path keeps this far inside the walls (the racing line's own margin)
REFERENCE_WEAR = 0.25  # tyre wear the shifted profiles are computed at (the race's start, as the line's)


@dataclass(frozen=True)
class ShiftedLines:
    """The racing line moved sideways by each of ``shifts`` [m] (clipped ``WALL_CLEARANCE`` inside the walls):
    each shifted path's positions and speed profile under the kart's limits. A kart driving off the line (in
    another lane: alongside, passing, defending) drives one of these paths, wider or tighter than the line, so
    its cornering and braking speeds are this path's, not the line's."""

    shifts: np.ndarray  # (K,) [m] left-positive shift from the line
    s: np.ndarray  # (M,) [m] centre-line progress of the samples (the line's)
    xy: np.ndarray  # (K, M, 2) [m] positions of each shifted path
    speed: np.ndarray  # (K, M) [m/s] speed profile of each shifted path

    @cached_property
    def _closed(self) -> tuple[float, np.ndarray, np.ndarray]:
        length = float(self.s[-1] + (self.s[1] - self.s[0]))
        return length, np.append(self.s, self.s[0] + length), np.concatenate([self.speed, self.speed[:, :1]], axis=1)

    def speed_at(self, s: float, shift: float) -> float:
        """Speed [m/s] of the path ``shift`` [m] beside the line at centre-line progress ``s`` (interpolated in
        both; shifts beyond the grid take its edge)."""
        length, s_closed, speed_closed = self._closed
        u = float(np.mod(s, length))
        k = int(np.clip(np.searchsorted(s_closed, u, side="right") - 1, 0, len(s_closed) - 2))
        f = (u - s_closed[k]) / max(s_closed[k + 1] - s_closed[k], 1e-9)
        x = float(np.clip((shift - self.shifts[0]) / SHIFT_STEP, 0.0, len(self.shifts) - 1.0))
        j = min(int(x), len(self.shifts) - 2)
        g = x - j
        low = speed_closed[j, k] + f * (speed_closed[j, k + 1] - speed_closed[j, k])
        high = speed_closed[j + 1, k] + f * (speed_closed[j + 1, k + 1] - speed_closed[j + 1, k])
        return float(low + g * (high - low))


_SHIFTED: dict[tuple[object, ...], ShiftedLines] = {}


def shifted_lines(track: Track, line: RacingLine, kart: KartParams) -> ShiftedLines:
    """:class:`ShiftedLines` of ``line`` on ``track`` at :data:`REFERENCE_WEAR`, cached per track, kart and line."""
    key = (track.name, float(track.length), track.n_checkpoints, kart, float(line.lap_time))
    cached = _SHIFTED.get(key)
    if cached is not None:
        return cached
    period = track.length
    centre = np.stack([np.interp(line.s, track.centre_s, track.centre_xy[:, k], period=period) for k in (0, 1)], 1)
    normal = np.stack([np.interp(line.s, track.centre_s, track.centre_normal[:, k], period=period) for k in (0, 1)], 1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    left = np.interp(line.s, track.centre_s, track.width_left, period=period) - WALL_CLEARANCE
    right = np.interp(line.s, track.centre_s, track.width_right, period=period) - WALL_CLEARANCE
    reach = float(np.max(left + right))
    shifts = np.arange(-reach, reach + SHIFT_STEP, SHIFT_STEP)
    xy = np.zeros((len(shifts), len(line.s), 2))
    speed = np.zeros((len(shifts), len(line.s)))
    for k, shift in enumerate(shifts):
        offset = np.clip(line.offset + shift, -right, left)
        xy[k] = centre + normal * offset[:, None]
        speed[k], _ = speed_profile(xy[k], kart, REFERENCE_WEAR)
    cached = _SHIFTED[key] = ShiftedLines(shifts, np.asarray(line.s, dtype=float), xy, speed)
    return cached
