"""Compiled geometry kernels: track-frame location, capsule distances, and wall ray casts.

Everything here is plain arithmetic on float64 scalars and arrays, compiled with numba and safe to call
from other compiled kernels. Angles are radians, counter-clockwise; distances metres.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from sim_core.track import Track

RAY_CELL = 2.0  # [m] cell size of the grid that holds each cell's candidate wall segments for ray casts
RAY_REACH = 20.0  # [m] longest ray the candidate lists serve (the sensors' range)
WALL_SIMPLIFY_TOLERANCE = 0.02  # [m] wall polyline points closer than this to a straight chord are merged
WALL_MAX_SEGMENT = 40.0  # [m] merged wall segments are kept at most this long
NEAR_WINDOW = 2.5  # [m] along-track reach of the near_width_* minima (more than half a kart's length)


class TrackArrays(NamedTuple):
    """A track flattened into arrays for the compiled kernels (see :func:`track_arrays`)."""

    centre_xy: np.ndarray  # (M, 2)
    centre_s: np.ndarray  # (M,)
    seg_tangent: np.ndarray  # (M, 2) unit vector from sample i to sample i+1
    seg_length: np.ndarray  # (M,) distance from sample i to sample i+1
    length: float
    width_left: np.ndarray  # (M,) wall distance
    width_right: np.ndarray  # (M,)
    near_width_left: np.ndarray  # (M,) smallest left wall distance within NEAR_WINDOW of the sample
    near_width_right: np.ndarray  # (M,) smallest right wall distance within NEAR_WINDOW of the sample
    checkpoint_s: np.ndarray  # (N,)
    checkpoint_centre: np.ndarray  # (N, 2)
    checkpoint_normal: np.ndarray  # (N, 2) left normal
    straight: np.ndarray  # (N,) bool: section i (checkpoint i -> i+1) is straight
    lane_offsets: np.ndarray  # (N, n_lanes) left-positive lateral offsets of the lanes at each checkpoint
    ray_origin: np.ndarray  # (2,) corner of the ray-candidate grid
    ray_cell: float  # [m]
    ray_shape: np.ndarray  # (2,) int64: nx, ny
    ray_start: np.ndarray  # (nx*ny + 1,) int64 CSR offsets into ray_segments
    ray_segments: np.ndarray  # (C, 4) [ax, ay, ex, ey] of the wall segments a ray from the cell can reach


def _simplify_closed(poly: np.ndarray, tol: float, max_len: float) -> np.ndarray:
    """Greedy merge of a closed polyline's points while every skipped point stays within ``tol`` of the chord."""
    keep = [0]
    n = len(poly)
    i = 0
    while i < n:
        j = i + 1
        best = j
        while j <= n:
            a, b = poly[i % n], poly[j % n]
            chord = b - a
            length = float(np.hypot(chord[0], chord[1]))
            if length > max_len:
                break
            mids = poly[[k % n for k in range(i + 1, j)]]
            if len(mids):
                rel = mids - a
                dist = np.abs(chord[0] * rel[:, 1] - chord[1] * rel[:, 0]) / max(length, 1e-12)
                if dist.max() > tol:
                    break
            best = j
            j += 1
        i = best
        if i < n:
            keep.append(i)
    return poly[keep]


def _sliding_min(values: np.ndarray, half_window: int) -> np.ndarray:
    """Minimum of a closed-loop array over +-``half_window`` samples."""
    out = values.astype(np.float64).copy()
    for shift in range(1, half_window + 1):
        out = np.minimum(out, np.minimum(np.roll(values, shift), np.roll(values, -shift)))
    return np.ascontiguousarray(out)


def _point_segment_distances(p: np.ndarray, a: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Distances from point ``p`` to every segment ``a -> a + e`` (vectorised)."""
    length2 = np.maximum(np.einsum("ij,ij->i", e, e), 1e-18)
    u = np.clip(np.einsum("ij,ij->i", p - a, e) / length2, 0.0, 1.0)
    closest = a + u[:, None] * e
    return np.hypot(closest[:, 0] - p[0], closest[:, 1] - p[1])


def track_arrays(track: Track) -> TrackArrays:
    """Flatten ``track`` for the kernels and build the per-cell wall candidate lists used by ray casts.

    Walls are simplified to chords within ``WALL_SIMPLIFY_TOLERANCE`` (ray distances are sensor readings;
    the physics uses the exact wall offsets). Every grid cell that a kart can occupy keeps the segments
    within ``RAY_REACH`` of it, stored contiguously so a fan of rays tests them in one tight loop.
    """
    segs_a, segs_e = [], []
    for wall in (track.left_wall, track.right_wall):
        pts = _simplify_closed(wall, WALL_SIMPLIFY_TOLERANCE, WALL_MAX_SEGMENT)
        segs_a.append(pts)
        segs_e.append(np.roll(pts, -1, axis=0) - pts)
    seg_a = np.vstack(segs_a)
    seg_e = np.vstack(segs_e)
    lo = np.minimum(seg_a, seg_a + seg_e).min(axis=0) - RAY_CELL
    hi = np.maximum(seg_a, seg_a + seg_e).max(axis=0) + RAY_CELL
    shape = np.ceil((hi - lo) / RAY_CELL).astype(np.int64)
    half_diagonal = RAY_CELL * np.sqrt(0.5)
    centre = track.centre_xy
    road = float(max(track.width_left.max(), track.width_right.max()))
    lists: list[np.ndarray] = []
    for cx in range(int(shape[0])):
        for cy in range(int(shape[1])):
            mid = lo + (np.array([cx, cy]) + 0.5) * RAY_CELL
            near_road = np.min(np.hypot(centre[:, 0] - mid[0], centre[:, 1] - mid[1])) <= road + half_diagonal + 0.5
            if not near_road:
                lists.append(np.empty((0, 4)))
                continue
            reach = _point_segment_distances(mid, seg_a, seg_e) <= RAY_REACH + half_diagonal + 0.5
            lists.append(np.hstack([seg_a[reach], seg_e[reach]]))
    start = np.zeros(len(lists) + 1, dtype=np.int64)
    start[1:] = np.cumsum([len(c) for c in lists])
    segments = np.vstack(lists) if start[-1] else np.zeros((0, 4))
    window = int(np.ceil(NEAR_WINDOW / float(np.mean(np.diff(track.centre_s)))))
    seg_vec = np.roll(track.centre_xy, -1, axis=0) - track.centre_xy
    seg_len = np.hypot(seg_vec[:, 0], seg_vec[:, 1])
    centres = np.array([track.checkpoint_frame(c)[0] for c in range(track.n_checkpoints)])
    normals = np.array([track.checkpoint_frame(c)[1] for c in range(track.n_checkpoints)])
    return TrackArrays(
        centre_xy=np.ascontiguousarray(track.centre_xy, dtype=np.float64),
        centre_s=np.ascontiguousarray(track.centre_s, dtype=np.float64),
        seg_tangent=np.ascontiguousarray(seg_vec / seg_len[:, None]),
        seg_length=np.ascontiguousarray(seg_len),
        length=float(track.length),
        width_left=np.ascontiguousarray(track.width_left, dtype=np.float64),
        width_right=np.ascontiguousarray(track.width_right, dtype=np.float64),
        near_width_left=_sliding_min(track.width_left, window),
        near_width_right=_sliding_min(track.width_right, window),
        checkpoint_s=np.ascontiguousarray(track.checkpoint_s, dtype=np.float64),
        checkpoint_centre=np.ascontiguousarray(centres, dtype=np.float64),
        checkpoint_normal=np.ascontiguousarray(normals, dtype=np.float64),
        straight=np.ascontiguousarray(track.straight_flags),
        lane_offsets=np.ascontiguousarray(np.stack([track.lane_offsets(c) for c in range(track.n_checkpoints)])),
        ray_origin=lo.astype(np.float64),
        ray_cell=float(RAY_CELL),
        ray_shape=shape,
        ray_start=start,
        ray_segments=np.ascontiguousarray(segments, dtype=np.float64),
    )


# --------------------------------------------------------------------------- scalar helpers
@njit(cache=True, inline="always")
def wrap_angle(a: float) -> float:
    """Angle wrapped to [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True, inline="always")
def locate(tr: TrackArrays, x: float, y: float, hint: int) -> tuple[int, float, float]:
    """(sample index, progress s, lateral offset d) of a point, by local search from sample ``hint``.

    The search walks along the centre line while the distance to the samples falls, so it follows a kart
    continuously (and stays on its own branch where two parts of the track run close to each other).
    """
    xy = tr.centre_xy
    m = xy.shape[0]
    i = hint
    if i < 0 or i >= m:
        i = 0
    best = (xy[i, 0] - x) ** 2 + (xy[i, 1] - y) ** 2
    for direction in (1, -1):
        while True:
            j = i + direction
            if j == m:
                j = 0
            elif j < 0:
                j = m - 1
            dj = (xy[j, 0] - x) ** 2 + (xy[j, 1] - y) ** 2
            if dj < best:
                i, best = j, dj
            else:
                break
    # project onto the segment on the point's side of sample i
    tx, ty = tr.seg_tangent[i, 0], tr.seg_tangent[i, 1]
    a = i
    if (x - xy[i, 0]) * tx + (y - xy[i, 1]) * ty < 0.0:
        a = i - 1 if i > 0 else m - 1
        tx, ty = tr.seg_tangent[a, 0], tr.seg_tangent[a, 1]
    rx, ry = x - xy[a, 0], y - xy[a, 1]
    along = min(max(rx * tx + ry * ty, 0.0), tr.seg_length[a])
    s = tr.centre_s[a] + along
    if s >= tr.length:
        s -= tr.length
    return i, s, tx * ry - ty * rx


@njit(cache=True, inline="always")
def centre_normal(tr: TrackArrays, i: int) -> tuple[float, float]:
    """Unit left normal of the centre line at sample ``i``."""
    xy = tr.centre_xy
    m = xy.shape[0]
    a = (i - 1) % m
    b = (i + 1) % m
    tx, ty = xy[b, 0] - xy[a, 0], xy[b, 1] - xy[a, 1]
    n = math.sqrt(tx * tx + ty * ty)
    return -ty / n, tx / n


@njit(cache=True)
def segment_closest(
    p0x: float, p0y: float, p1x: float, p1y: float, q0x: float, q0y: float, q1x: float, q1y: float
) -> tuple[float, float, float]:
    """Closest points of segments P0P1 and Q0Q1: (distance, parameter on P, parameter on Q)."""
    d1x, d1y = p1x - p0x, p1y - p0y
    d2x, d2y = q1x - q0x, q1y - q0y
    rx, ry = p0x - q0x, p0y - q0y
    a = d1x * d1x + d1y * d1y
    e = d2x * d2x + d2y * d2y
    f = d2x * rx + d2y * ry
    c = d1x * rx + d1y * ry
    b = d1x * d2x + d1y * d2y
    denom = a * e - b * b
    s = 0.0
    if denom > 1e-12:
        s = min(max((b * f - c * e) / denom, 0.0), 1.0)
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0)
    dx = p0x + d1x * s - (q0x + d2x * t)
    dy = p0y + d1y * s - (q0y + d2y * t)
    return math.sqrt(dx * dx + dy * dy), s, t


@njit(cache=True, inline="always")
def point_segment_distance(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """Distance from point P to segment AB."""
    ex, ey = bx - ax, by - ay
    length2 = ex * ex + ey * ey
    u = 0.0 if length2 < 1e-18 else min(max(((px - ax) * ex + (py - ay) * ey) / length2, 0.0), 1.0)
    dx, dy = ax + u * ex - px, ay + u * ey - py
    return math.sqrt(dx * dx + dy * dy)


@njit(cache=True, inline="always")
def ray_circle(ox: float, oy: float, dx: float, dy: float, cx: float, cy: float, r: float) -> float:
    """Distance along the unit ray to a circle, or inf (rays starting inside hit at 0)."""
    fx, fy = ox - cx, oy - cy
    b = fx * dx + fy * dy
    c = fx * fx + fy * fy - r * r
    if c <= 0.0:
        return 0.0
    disc = b * b - c
    if disc < 0.0 or b > 0.0:
        return math.inf
    return -b - math.sqrt(disc)


@njit(cache=True)
def ray_capsule(
    ox: float, oy: float, dx: float, dy: float, ax: float, ay: float, bx: float, by: float, r: float
) -> float:
    """Distance along the unit ray to the capsule around segment AB with radius ``r``, or inf."""
    best = min(ray_circle(ox, oy, dx, dy, ax, ay, r), ray_circle(ox, oy, dx, dy, bx, by, r))
    ex, ey = bx - ax, by - ay
    length = math.sqrt(ex * ex + ey * ey)
    if length < 1e-12:
        return best
    ux, uy = ex / length, ey / length
    nx, ny = -uy, ux
    for side in (1.0, -1.0):
        # the side line: points q with (q - a) . n == side * r
        denom = dx * nx + dy * ny
        if abs(denom) < 1e-12:
            continue
        t = (side * r - ((ox - ax) * nx + (oy - ay) * ny)) / denom
        if 0.0 <= t < best:
            hx, hy = ox + t * dx - ax, oy + t * dy - ay
            along = hx * ux + hy * uy
            if 0.0 <= along <= length:
                best = t
    return best


@njit(cache=True, inline="always")
def ray_fan_walls(
    tr: TrackArrays, ox: float, oy: float, dxs: np.ndarray, dys: np.ndarray, max_range: float, out: np.ndarray
) -> None:
    """Distances from (ox, oy) along each unit direction (dxs[i], dys[i]) to the first wall, capped at
    ``max_range`` (which must not exceed ``RAY_REACH``), written to ``out``.

    All rays of the fan test the candidate list of the origin's cell. Segments entirely behind every ray
    of the fan are skipped; the intersection test uses no division until a hit is certain.
    """
    n = dxs.shape[0]
    for i in range(n):
        out[i] = max_range
    cx = math.floor((ox - tr.ray_origin[0]) / tr.ray_cell)
    cy = math.floor((oy - tr.ray_origin[1]) / tr.ray_cell)
    if cx < 0 or cy < 0 or cx >= tr.ray_shape[0] or cy >= tr.ray_shape[1]:
        return
    # the fan's mean direction: a segment with both ends behind the fan's half plane cannot be hit when the
    # fan spans at most 180 degrees
    fx, fy = 0.0, 0.0
    for i in range(n):
        fx += dxs[i]
        fy += dys[i]
    cull = True
    for i in range(n):
        if dxs[i] * fx + dys[i] * fy < -1e-9:
            cull = False
    c = cx * tr.ray_shape[1] + cy
    segs = tr.ray_segments
    for q in range(tr.ray_start[c], tr.ray_start[c + 1]):
        wx = segs[q, 0] - ox
        wy = segs[q, 1] - oy
        ex = segs[q, 2]
        ey = segs[q, 3]
        if cull and wx * fx + wy * fy < 0.0 and (wx + ex) * fx + (wy + ey) * fy < 0.0:
            continue
        t_num = wx * ey - wy * ex
        for i in range(n):
            denom = dxs[i] * ey - dys[i] * ex
            u_num = wx * dys[i] - wy * dxs[i]
            sign = 1.0 if denom > 0.0 else -1.0
            tn = t_num * sign
            un = u_num * sign
            ad = denom * sign
            if tn >= 0.0 and un >= 0.0 and un <= ad and tn < out[i] * ad:
                out[i] = tn / ad


@njit(cache=True)
def ray_walls(tr: TrackArrays, ox: float, oy: float, dx: float, dy: float, max_range: float) -> float:
    """Distance along one unit ray from (ox, oy) to the first wall, capped at ``max_range``."""
    dxs = np.array([dx])
    dys = np.array([dy])
    out = np.empty(1)
    ray_fan_walls(tr, ox, oy, dxs, dys, max_range, out)
    return out[0]
