"""Compiled geometry kernels: track-frame location, capsule distances, and wall ray casts.

Everything here is plain arithmetic on float64 scalars and arrays, compiled with numba and safe to call
from other compiled kernels. Angles are radians, counter-clockwise; distances metres.

Wall ray casts read a grid over the track built once per track (:func:`ray_grid`): per cell, every wall
within the sensors' reach (exact from any origin), and per cell and direction bin, the few walls that a ray
from the track can hit first (about 3.5 per ray on ``complex`` instead of about 55), found offline by
exact visibility sweeps.
"""

from __future__ import annotations

import hashlib
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
RAY_BINS = 64  # direction bins of the ray grid's candidate lists (at most 64)
RAY_BIN_MARGIN = math.radians(0.5)  # [rad] a bin's list also serves directions this far outside it ...
RAY_SAMPLE_STEP = 0.1  # [m] ... and origins this far from the ones sampled along its cell's boundary
RAY_PARALLAX_FLOOR = 0.5  # [m] parallax margins are computed as if no end point were nearer than this
RAY_KEEP_NEAR = 0.5  # [m] wall segments this close to a sampled origin are listed in every bin they span


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
    sample_lane_offsets: np.ndarray  # (M, n_lanes) the same at every centre-line sample
    wall_segments: np.ndarray  # (W, 4) [ax, ay, ex, ey] of every (simplified) wall segment
    ray_origin: np.ndarray  # (2,) corner of the ray grid
    ray_cell: float  # [m] its cell size
    ray_shape: np.ndarray  # (2,) int64: nx, ny
    ray_start: np.ndarray  # (nx*ny + 1,) int64 CSR offsets into ray_segments, cell cx*ny + cy
    ray_segments: np.ndarray  # (C, 4) [ax, ay, ex, ey] of the wall segments within reach of the cell
    ray_bins: int  # direction bins per cell
    ray_bin_start: np.ndarray  # (nx*ny*bins + 1,) int32 CSR offsets into ray_bin_index, slot (cx*ny + cy)*bins + bin
    ray_bin_index: np.ndarray  # (D,) uint16 (or uint32) rows of wall_segments that may be hit first from the slot


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


def track_arrays(track: Track) -> TrackArrays:
    """Flatten ``track`` for the kernels and build the ray grid (see :func:`ray_grid`).

    Walls are simplified to chords within ``WALL_SIMPLIFY_TOLERANCE`` (ray distances are sensor readings;
    the physics uses the exact wall offsets).
    """
    segs_a, segs_e, sides = [], [], []
    for wall in (track.left_wall, track.right_wall):
        pts = _simplify_closed(wall, WALL_SIMPLIFY_TOLERANCE, WALL_MAX_SEGMENT)
        e = np.roll(pts, -1, axis=0) - pts
        segs_a.append(pts)
        segs_e.append(e)
        sides.append(np.full(len(pts), _interior_side(pts, e, track.centre_xy)))
    seg_a = np.ascontiguousarray(np.vstack(segs_a), dtype=np.float64)
    seg_e = np.ascontiguousarray(np.vstack(segs_e), dtype=np.float64)
    road = float(max(track.width_left.max(), track.width_right.max()))
    grid = ray_grid(seg_a, seg_e, np.concatenate(sides), len(segs_a[0]), track.centre_xy, road)
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
        sample_lane_offsets=np.ascontiguousarray(track.sample_lane_offsets(), dtype=np.float64),
        wall_segments=np.ascontiguousarray(np.hstack([seg_a, seg_e])),
        ray_origin=grid.origin,
        ray_cell=float(RAY_CELL),
        ray_shape=grid.shape,
        ray_start=grid.reach_start,
        ray_segments=grid.reach_segments,
        ray_bins=int(RAY_BINS),
        ray_bin_start=grid.bin_start,
        ray_bin_index=grid.bin_index,
    )


def _interior_side(pts: np.ndarray, e: np.ndarray, centre: np.ndarray) -> float:
    """+1 when the track lies to the left of a wall's segments (cross(e, p - a) > 0), else -1 (the majority
    over the segments of the side their nearest centre sample is on)."""
    mid = pts + 0.5 * e
    votes = 0.0
    for m, a, ee in zip(mid, pts, e):
        j = int(np.argmin((centre[:, 0] - m[0]) ** 2 + (centre[:, 1] - m[1]) ** 2))
        votes += np.sign(ee[0] * (centre[j, 1] - a[1]) - ee[1] * (centre[j, 0] - a[0]))
    return 1.0 if votes >= 0.0 else -1.0


class RayGrid(NamedTuple):
    """The ray grid (see :func:`ray_grid`)."""

    origin: np.ndarray  # (2,) corner
    shape: np.ndarray  # (2,) int64: nx, ny
    reach_start: np.ndarray  # (nx*ny + 1,) int64 CSR offsets into reach_segments
    reach_segments: np.ndarray  # (C, 4) every wall segment within RAY_REACH of the cell
    bin_start: np.ndarray  # (nx*ny*bins + 1,) int32 CSR offsets into bin_index
    bin_index: np.ndarray  # (D,) uint16 (uint32 for more than 65536 segments) wall segment indices


_RAY_GRID_CACHE: dict[bytes, RayGrid] = {}  # the most recently used grids, by wall geometry and settings
_RAY_GRID_CACHE_SIZE = 8


def ray_grid(
    seg_a: np.ndarray,
    seg_e: np.ndarray,
    side: np.ndarray,
    n_left: int,
    centre: np.ndarray,
    road: float,
    *,
    cell: float = RAY_CELL,
    bins: int = RAY_BINS,
    sample_step: float = RAY_SAMPLE_STEP,
    margin: float = RAY_BIN_MARGIN,
    parallax_floor: float = RAY_PARALLAX_FLOOR,
    keep_near: float = RAY_KEEP_NEAR,
) -> RayGrid:
    """The ray grid of the walls ``a -> a + e`` (left wall first, ``n_left`` segments, then the right wall;
    ``side``: the sign of cross(e, p - a) for points p on the track), cells of ``cell`` metres:

    * ``reach_*``: each cell near the road lists (copies of) the segments within ``RAY_REACH`` of it: every
      wall that a ray from anywhere in the cell can reach (exact for any origin);
    * ``bin_*``: per cell and direction bin, the (indices of the) segments that a ray from an on-track
      point of the cell in that direction may hit FIRST.

    Slot ``(cx * ny + cy) * bins + j`` lists the walls that a ray from the cell whose direction lies in bin
    j (angles [-pi + j w, -pi + (j + 1) w), w = 2 pi / bins) may hit FIRST within ``RAY_REACH``:

    * the candidates are the cell's reach list;
    * a cell that holds on-track points (between the walls) lists a segment in a bin when it is the first
      hit of a ray in (or near) the bin from some on-track point of the cell. A segment seen from inside a
      region in some direction is also seen, in that direction, from the region's boundary behind the
      origin, so origins are sampled every ``sample_step`` along the boundary of the cell's on-track part
      (its edges, and its walls just on their track side). From each origin the visible set is exact:
      between two consecutive end-point angles no segment starts or ends (walls do not cross), so one ray
      per wedge finds the first segment there; segments facing away are never hit first from the track.
      Each wedge is widened by ``margin`` plus the parallax of its bounding end points for an origin
      ``sample_step`` away (``asin(sample_step / max(distance, parallax_floor))``), and segments within
      ``keep_near`` of an origin are listed in every bin they span, occluded or not;
    * a cell without on-track points lists a segment in every bin that some ray from the cell toward it
      falls in (no occlusion).

    Should walls cross (not on a well-formed track), their crossing points are sweep events too, and every
    origin sampled in a cell counts, facing or not. Results are memoised per wall geometry and settings
    (worlds often share a track).
    """
    settings = np.array([n_left, road, cell, bins, sample_step, margin, parallax_floor, keep_near, RAY_REACH])
    key = hashlib.sha1(
        b"".join(np.ascontiguousarray(v, dtype=np.float64).tobytes() for v in (seg_a, seg_e, side, centre, settings))
    ).digest()
    cached = _RAY_GRID_CACHE.pop(key, None)
    if cached is not None:
        _RAY_GRID_CACHE[key] = cached  # most recent last
        return cached
    if not 1 <= bins <= 64:
        raise ValueError(f"bins must be in 1..64, got {bins}")
    seg_a = np.ascontiguousarray(seg_a, dtype=np.float64)
    seg_e = np.ascontiguousarray(seg_e, dtype=np.float64)
    side = np.ascontiguousarray(side, dtype=np.float64)
    n = len(seg_a)
    nxt = np.arange(1, n + 1)
    nxt[n_left - 1] = 0
    nxt[n - 1] = n_left
    lo = np.minimum(seg_a, seg_a + seg_e).min(axis=0) - cell
    hi = np.maximum(seg_a, seg_a + seg_e).max(axis=0) + cell
    shape = np.ceil((hi - lo) / cell).astype(np.int64)
    crossings = _wall_crossings(seg_a, seg_e, nxt)
    cand_start, cand_idx = _reach_candidates(
        seg_a, seg_e, np.ascontiguousarray(centre, dtype=np.float64), road, lo, cell, shape[0], shape[1]
    )
    row_start, row_idx = _row_lists(seg_a, seg_e, lo, cell, shape[1])
    marks = _visible_marks(
        seg_a,
        seg_e,
        side,
        lo,
        cell,
        shape[0],
        shape[1],
        cand_start,
        cand_idx,
        row_start,
        row_idx,
        crossings,
        bins,
        sample_step,
        margin,
        parallax_floor,
        keep_near,
    )
    start, index = _gather_lists(cand_start, cand_idx, marks, bins)
    # compact types keep the grid small in the caches (the kernels are compiled per type)
    index = index.astype(np.uint16) if n <= 2**16 else index.astype(np.uint32)
    result = RayGrid(
        origin=lo.astype(np.float64),
        shape=shape,
        reach_start=cand_start,
        reach_segments=np.ascontiguousarray(np.hstack([seg_a[cand_idx], seg_e[cand_idx]])),
        bin_start=start.astype(np.int32) if start[-1] < 2**31 else start,
        bin_index=index,
    )
    _RAY_GRID_CACHE[key] = result
    while len(_RAY_GRID_CACHE) > _RAY_GRID_CACHE_SIZE:
        del _RAY_GRID_CACHE[next(iter(_RAY_GRID_CACHE))]
    return result


@njit(cache=True)
def _wall_crossings(seg_a: np.ndarray, seg_e: np.ndarray, nxt: np.ndarray) -> np.ndarray:
    """(k, 2) points where two wall segments that are not neighbours meet (none on a well-formed track)."""
    n = seg_a.shape[0]
    out = np.empty((0, 2))
    for fill in range(2):  # count, then fill
        count = 0
        for q in range(n):
            for r in range(q + 1, n):
                if nxt[q] == r or nxt[r] == q:
                    continue
                den = seg_e[q, 0] * seg_e[r, 1] - seg_e[q, 1] * seg_e[r, 0]
                if den == 0.0:
                    continue
                wx, wy = seg_a[r, 0] - seg_a[q, 0], seg_a[r, 1] - seg_a[q, 1]
                u = (wx * seg_e[r, 1] - wy * seg_e[r, 0]) / den
                v = (wx * seg_e[q, 1] - wy * seg_e[q, 0]) / den
                if 0.0 <= u <= 1.0 and 0.0 <= v <= 1.0:
                    if fill:
                        out[count, 0] = seg_a[q, 0] + u * seg_e[q, 0]
                        out[count, 1] = seg_a[q, 1] + u * seg_e[q, 1]
                    count += 1
        if not fill:
            out = np.empty((count, 2))
    return out


@njit(cache=True)
def _reach_candidates(
    seg_a: np.ndarray,
    seg_e: np.ndarray,
    centre: np.ndarray,
    road: float,
    lo: np.ndarray,
    cell: float,
    nx: int,
    ny: int,
) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists (start, segment indices) of the segments within reach of each cell near the road."""
    half_diagonal = cell * math.sqrt(0.5)
    near2 = (road + half_diagonal + 0.5) ** 2
    reach = RAY_REACH + half_diagonal + 0.5
    n = seg_a.shape[0]
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    idx = []
    for cx in range(nx):
        for cy in range(ny):
            c = cx * ny + cy
            mx = lo[0] + (cx + 0.5) * cell
            my = lo[1] + (cy + 0.5) * cell
            near_road = False
            for i in range(centre.shape[0]):
                if (centre[i, 0] - mx) ** 2 + (centre[i, 1] - my) ** 2 <= near2:
                    near_road = True
                    break
            count = 0
            if near_road:
                for q in range(n):
                    dist = point_segment_distance(
                        mx, my, seg_a[q, 0], seg_a[q, 1], seg_a[q, 0] + seg_e[q, 0], seg_a[q, 1] + seg_e[q, 1]
                    )
                    if dist <= reach:
                        idx.append(q)
                        count += 1
            start[c + 1] = start[c] + count
    out = np.empty(len(idx), dtype=np.int64)
    for i in range(len(idx)):
        out[i] = idx[i]
    return start, out


@njit(cache=True)
def _row_lists(
    seg_a: np.ndarray, seg_e: np.ndarray, lo: np.ndarray, cell: float, ny: int
) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists (start, segment indices) of the segments whose y-extent meets each row of cells (+-1 row)."""
    n = seg_a.shape[0]
    counts = np.zeros(ny + 1, dtype=np.int64)
    rows = np.empty((n, 2), dtype=np.int64)
    for q in range(n):
        y_lo = min(seg_a[q, 1], seg_a[q, 1] + seg_e[q, 1])
        y_hi = max(seg_a[q, 1], seg_a[q, 1] + seg_e[q, 1])
        r0 = max(math.floor((y_lo - lo[1]) / cell) - 1, 0)
        r1 = min(math.floor((y_hi - lo[1]) / cell) + 1, ny - 1)
        rows[q, 0], rows[q, 1] = r0, r1
        for r in range(r0, r1 + 1):
            counts[r + 1] += 1
    start = np.cumsum(counts)
    fill = start[:-1].copy()
    idx = np.empty(start[-1], dtype=np.int64)
    for q in range(n):
        for r in range(rows[q, 0], rows[q, 1] + 1):
            idx[fill[r]] = q
            fill[r] += 1
    return start, idx


@njit(cache=True)
def _in_region(px: float, py: float, seg_a: np.ndarray, seg_e: np.ndarray, row: np.ndarray) -> bool:
    """Even-odd test: is the point between the walls? (``row`` must hold every segment whose y-extent
    contains py.)"""
    inside = False
    for q in row:
        ay, by = seg_a[q, 1], seg_a[q, 1] + seg_e[q, 1]
        if (ay > py) != (by > py):
            x_cross = seg_a[q, 0] + (py - ay) * seg_e[q, 0] / seg_e[q, 1]
            if px < x_cross:
                inside = not inside
    return inside


@njit(cache=True, inline="always")
def _arc_bins(start: float, length: float, bins: int) -> np.uint64:
    """Bit mask of the direction bins that the arc [start, start + length] (radians) overlaps."""
    if length >= 2.0 * math.pi or bins == 1:
        return np.uint64(0xFFFFFFFFFFFFFFFF) >> np.uint64(64 - bins)
    w = 2.0 * math.pi / bins
    j0 = math.floor((start + math.pi) / w)
    j1 = math.floor((start + length + math.pi) / w)
    mask = np.uint64(0)
    for j in range(j0, j1 + 1):
        mask |= np.uint64(1) << np.uint64(j % bins)
    return mask


@njit(cache=True, inline="always")
def _parallax(distance: float, step: float, floor: float) -> float:
    """Largest change [rad] of the direction to a point ``distance`` away when the origin moves ``step``."""
    return math.asin(min(1.0, step / max(distance, floor)))


@njit(cache=True)
def _mark_from_point(
    px: float,
    py: float,
    seg_a: np.ndarray,
    seg_e: np.ndarray,
    side: np.ndarray,
    cand: np.ndarray,
    seen: np.ndarray,
    crossings: np.ndarray,
    well_formed: bool,
    bins: int,
    step: float,
    margin: float,
    floor: float,
    keep_near: float,
    work: np.ndarray,
    active: np.ndarray,
    act: np.ndarray,
    _order: np.ndarray,
) -> None:
    """OR into ``seen[q]`` the direction bins in which wall segment q (one of ``cand``) is (nearly) the first
    wall hit by a ray from (px, py) (see :func:`ray_grid`). ``work`` ((2 n + k, 6)), ``_order`` (as long),
    ``active`` (zeros) and ``act`` (both as long as ``cand``) are work arrays."""
    two_pi = 2.0 * math.pi
    reach2 = RAY_REACH * RAY_REACH
    # the angular interval [start, start + span] (counter-clockwise) of every segment facing the point;
    # events: rows [angle, +1 start / -1 end / 0 crossing, candidate, distance of the end point, its unit
    # direction x, y]; the active segments (those whose interval holds the current angle) are act[:n_act],
    # active[i] = slot + 1
    ne = 0
    n_act = 0
    for i in range(cand.shape[0]):
        q = cand[i]
        ax, ay, ex, ey = seg_a[q, 0], seg_a[q, 1], seg_e[q, 0], seg_e[q, 1]
        rax, ray_ = ax - px, ay - py
        rbx, rby = rax + ex, ray_ + ey
        turn = rax * rby - ray_ * rbx  # > 0: a -> b runs counter-clockwise around the point
        if turn == 0.0:
            continue  # seen edge-on: never hit
        if well_formed and side[q] * (ex * -ray_ - ey * -rax) <= 0.0:
            continue  # seen from behind: a wall in front of it is hit first
        length2 = ex * ex + ey * ey
        u = min(max(-(rax * ex + ray_ * ey) / length2, 0.0), 1.0)
        cx, cy = rax + u * ex, ray_ + u * ey
        near2 = cx * cx + cy * cy
        if near2 > reach2:
            continue
        da = math.sqrt(rax * rax + ray_ * ray_)
        db = math.sqrt(rbx * rbx + rby * rby)
        ta = math.atan2(ray_, rax)
        tb = math.atan2(rby, rbx)
        if turn > 0.0:
            s0, d0, s1, d1 = ta, da, tb, db
            v0x, v0y, v1x, v1y = rax, ray_, rbx, rby
        else:
            s0, d0, s1, d1 = tb, db, ta, da
            v0x, v0y, v1x, v1y = rbx, rby, rax, ray_
        span = (s1 - s0) % two_pi
        work[ne, 0], work[ne, 1], work[ne, 2], work[ne, 3] = s0, 1.0, i, d0
        work[ne, 4], work[ne, 5] = v0x / d0, v0y / d0
        work[ne + 1, 0], work[ne + 1, 1], work[ne + 1, 2], work[ne + 1, 3] = s1, -1.0, i, d1
        work[ne + 1, 4], work[ne + 1, 5] = v1x / d1, v1y / d1
        ne += 2
        if s0 + span > math.pi:  # wraps past +-pi: active at the start of the sweep
            active[i] = n_act + 1
            act[n_act] = i
            n_act += 1
        if near2 <= keep_near * keep_near:
            lo_m = margin + _parallax(d0, step, 0.0)
            hi_m = margin + _parallax(d1, step, 0.0)
            seen[q] |= _arc_bins(s0 - lo_m, span + lo_m + hi_m, bins)
    if ne == 0:
        return
    if not well_formed:
        for k in range(crossings.shape[0]):
            dx, dy = crossings[k, 0] - px, crossings[k, 1] - py
            dist = math.hypot(dx, dy)
            if dist == 0.0:
                continue
            work[ne, 0], work[ne, 1], work[ne, 2], work[ne, 3] = math.atan2(dy, dx), 0.0, -1.0, dist
            work[ne, 4], work[ne, 5] = dx / dist, dy / dist
            ne += 1
    # sort the events by angle (insertion sort: a few dozen, mostly in order already)
    order = _order
    for k in range(ne):
        order[k] = k
    for k in range(1, ne):
        e = order[k]
        angle = work[e, 0]
        m = k - 1
        while m >= 0 and work[order[m], 0] > angle:
            order[m + 1] = order[m]
            m -= 1
        order[m + 1] = e
    for k in range(ne):
        e = order[k]
        i = int(work[e, 2])
        if work[e, 1] > 0.0 and active[i] == 0:
            active[i] = n_act + 1
            act[n_act] = i
            n_act += 1
        elif work[e, 1] < 0.0 and active[i] > 0:
            slot = active[i] - 1
            n_act -= 1
            last = act[n_act]
            act[slot] = last
            active[last] = slot + 1
            active[i] = 0
        nk = order[k + 1] if k + 1 < ne else order[0]
        a0 = work[e, 0]
        a1 = work[nk, 0] if k + 1 < ne else work[nk, 0] + two_pi
        if a1 - a0 <= 1e-12 or n_act == 0:
            continue
        if a1 - a0 < 3.0:  # the wedge's bisector (any direction inside it would do; length is irrelevant)
            dx, dy = work[e, 4] + work[nk, 4], work[e, 5] + work[nk, 5]
        else:
            mid = 0.5 * (a0 + a1)
            dx, dy = math.cos(mid), math.sin(mid)
        best_tn, best_ad = math.inf, 1.0
        hit = -1
        for f in range(n_act):
            i = act[f]
            q = cand[i]
            ex, ey = seg_e[q, 0], seg_e[q, 1]
            wx, wy = seg_a[q, 0] - px, seg_a[q, 1] - py
            den = dx * ey - dy * ex
            sign = 1.0 if den > 0.0 else -1.0
            tn = (wx * ey - wy * ex) * sign
            un = (wx * dy - wy * dx) * sign
            ad = den * sign
            if ad > 0.0 and tn >= 0.0 and 0.0 <= un <= ad and tn * best_ad < best_tn * ad:
                best_tn, best_ad, hit = tn, ad, i
        if hit >= 0:
            lo_m = margin + _parallax(work[e, 3], step, floor)
            hi_m = margin + _parallax(work[nk, 3], step, floor)
            seen[cand[hit]] |= _arc_bins(a0 - lo_m, a1 - a0 + lo_m + hi_m, bins)
    for f in range(n_act):
        active[act[f]] = 0


@njit(cache=True)
def _square_arc(x0: float, y0: float, size: float, ax: float, ay: float, bx: float, by: float) -> tuple[float, float]:
    """(start, span) of the directions from points of the square [x0, x0 + size]^2 to points of segment AB
    (span 2 pi when they meet): the directions of the convex set AB - square, spanned by its corners."""
    two_pi = 2.0 * math.pi
    angles = np.empty(8)
    k = 0
    for px, py in ((ax, ay), (bx, by)):
        for cx, cy in ((x0, y0), (x0 + size, y0), (x0, y0 + size), (x0 + size, y0 + size)):
            angles[k] = math.atan2(py - cy, px - cx)
            k += 1
    for i in range(1, 8):  # insertion sort
        a = angles[i]
        m = i - 1
        while m >= 0 and angles[m] > a:
            angles[m + 1] = angles[m]
            m -= 1
        angles[m + 1] = a
    gap, at = angles[0] + two_pi - angles[7], 0
    for i in range(1, 8):
        if angles[i] - angles[i - 1] > gap:
            gap, at = angles[i] - angles[i - 1], i
    if gap <= math.pi:
        return 0.0, two_pi  # the segment may cross the square: any direction
    return angles[at], two_pi - gap


@njit(cache=True)
def _visible_marks(
    seg_a: np.ndarray,
    seg_e: np.ndarray,
    side: np.ndarray,
    lo: np.ndarray,
    cell: float,
    nx: int,
    ny: int,
    cand_start: np.ndarray,
    cand_idx: np.ndarray,
    row_start: np.ndarray,
    row_idx: np.ndarray,
    crossings: np.ndarray,
    bins: int,
    step: float,
    margin: float,
    floor: float,
    keep_near: float,
) -> np.ndarray:
    """Per candidate (in CSR order): the bit mask of the bins it is listed in (see :func:`ray_grid`)."""
    n = seg_a.shape[0]
    well_formed = crossings.shape[0] == 0
    n_edge = max(math.ceil(cell / step), 1)
    # the origins, each with the (up to four) cells whose closed square holds it: first the walls' pieces
    # inside each cell, just on their track side, then the cells' edges, each sampled once for both (at
    # corners: all four) cells holding it
    crossed = np.zeros(nx * ny, dtype=np.bool_)
    inside = np.zeros(nx * ny, dtype=np.bool_)
    pts = np.empty((1024, 2))
    owners = np.empty((1024, 4), dtype=np.int64)
    m = 0
    for c in range(nx * ny):
        if cand_start[c] == cand_start[c + 1]:
            continue
        x0 = lo[0] + (c // ny) * cell
        y0 = lo[1] + (c % ny) * cell
        for i in range(cand_start[c], cand_start[c + 1]):
            q = cand_idx[i]
            ax, ay, ex, ey = seg_a[q, 0], seg_a[q, 1], seg_e[q, 0], seg_e[q, 1]
            u0, u1 = 0.0, 1.0
            for pdir, qdist in ((-ex, ax - x0), (ex, x0 + cell - ax), (-ey, ay - y0), (ey, y0 + cell - ay)):
                if pdir == 0.0:
                    if qdist < 0.0:
                        u0, u1 = 1.0, 0.0
                else:
                    r = qdist / pdir
                    if pdir < 0.0:
                        u0 = max(u0, r)
                    else:
                        u1 = min(u1, r)
            length = math.sqrt(ex * ex + ey * ey)
            if u0 > u1 or length == 0.0:
                continue
            crossed[c] = True
            ox = side[q] * -ey / length * 1e-6
            oy = side[q] * ex / length * 1e-6
            k_max = math.ceil((u1 - u0) * length / step)
            for k in range(k_max + 1):
                u = u0 + (u1 - u0) * k / max(k_max, 1)
                if m == pts.shape[0]:
                    pts, owners = _grow(pts, owners)
                pts[m, 0], pts[m, 1] = ax + u * ex + ox, ay + u * ey + oy
                owners[m, 0], owners[m, 1], owners[m, 2], owners[m, 3] = c, -1, -1, -1
                m += 1
        if not crossed[c]:
            row = row_idx[row_start[c % ny] : row_start[c % ny + 1]]
            inside[c] = _in_region(x0 + 0.5 * cell, y0 + 0.5 * cell, seg_a, seg_e, row)
    for i in range(nx + 1):
        for j in range(ny + 1):
            left = (i - 1) * ny + j if i > 0 and j < ny else -1
            right = i * ny + j if i < nx and j < ny else -1
            below_left = (i - 1) * ny + j - 1 if i > 0 and j > 0 else -1
            below_right = i * ny + j - 1 if i < nx and j > 0 else -1
            for k in range(2 * n_edge - 1):  # the corner, up the vertical edge, along the horizontal one
                f = ((k + 1) // 2) * cell / n_edge
                if k == 0:
                    px, py, a, b, c, d = 0.0, 0.0, left, right, below_left, below_right
                elif k % 2 == 1:
                    px, py, a, b, c, d = 0.0, f, left, right, -1, -1
                else:
                    px, py, a, b, c, d = f, 0.0, below_right, right, -1, -1
                if max(a, b, c, d) < 0:
                    continue
                if m == pts.shape[0]:
                    pts, owners = _grow(pts, owners)
                pts[m, 0], pts[m, 1] = lo[0] + i * cell + px, lo[1] + j * cell + py
                owners[m, 0], owners[m, 1], owners[m, 2], owners[m, 3] = a, b, c, d
                m += 1
    # from each on-track origin: the first-hit bins of what it sees, into every cell holding it
    marks = np.zeros(cand_idx.shape[0], dtype=np.uint64)
    counts = np.zeros(nx * ny, dtype=np.int64)
    seen = np.zeros(n, dtype=np.uint64)
    work = np.empty((2 * n + crossings.shape[0], 6))
    order = np.empty(work.shape[0], dtype=np.int64)
    active = np.zeros(n, dtype=np.int64)
    act = np.zeros(n, dtype=np.int64)
    for p in range(m):
        first = -1
        on_track = True
        for c in owners[p]:
            if c >= 0 and cand_start[c] < cand_start[c + 1]:
                if first < 0:
                    first = c
                if well_formed and not crossed[c]:
                    on_track = inside[c]  # a cell that no wall crosses lies wholly on or off the track
        if first < 0 or not on_track:
            continue
        px, py = pts[p, 0], pts[p, 1]
        if well_formed and crossed[first]:
            row = row_idx[row_start[first % ny] : row_start[first % ny + 1]]
            if not _in_region(px, py, seg_a, seg_e, row):
                continue
        # any cell holding the point lists every segment within reach of it
        cand = cand_idx[cand_start[first] : cand_start[first + 1]]
        _mark_from_point(
            px,
            py,
            seg_a,
            seg_e,
            side,
            cand,
            seen,
            crossings,
            well_formed,
            bins,
            step,
            margin,
            floor,
            keep_near,
            work,
            active,
            act,
            order,
        )
        for c in owners[p]:
            if c >= 0 and cand_start[c] < cand_start[c + 1]:
                counts[c] += 1
                for i in range(cand_start[c], cand_start[c + 1]):
                    marks[i] |= seen[cand_idx[i]]
        for q in cand:
            seen[q] = 0
    # cells without on-track origins: every segment in the directions toward it
    for c in range(nx * ny):
        if counts[c] > 0:
            continue
        x0 = lo[0] + (c // ny) * cell
        y0 = lo[1] + (c % ny) * cell
        for i in range(cand_start[c], cand_start[c + 1]):
            q = cand_idx[i]
            s0, span = _square_arc(
                x0, y0, cell, seg_a[q, 0], seg_a[q, 1], seg_a[q, 0] + seg_e[q, 0], seg_a[q, 1] + seg_e[q, 1]
            )
            marks[i] = _arc_bins(s0 - margin, span + 2.0 * margin, bins)
    return marks


@njit(cache=True)
def _grow(pts: np.ndarray, owners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``pts`` and ``owners`` with twice the rows (the first ones copied)."""
    new_pts = np.empty((2 * pts.shape[0], 2))
    new_owners = np.empty((2 * owners.shape[0], 4), dtype=np.int64)
    for i in range(pts.shape[0]):
        new_pts[i, 0], new_pts[i, 1] = pts[i, 0], pts[i, 1]
        for j in range(4):
            new_owners[i, j] = owners[i, j]
    return new_pts, new_owners


@njit(cache=True)
def _gather_lists(
    cand_start: np.ndarray, cand_idx: np.ndarray, marks: np.ndarray, bins: int
) -> tuple[np.ndarray, np.ndarray]:
    """CSR (start over the cell x bin slots, segment indices) of the listed segments."""
    n_cells = cand_start.shape[0] - 1
    total = 0
    for i in range(marks.shape[0]):
        m = marks[i]
        while m:
            total += 1
            m &= m - np.uint64(1)
    start = np.zeros(n_cells * bins + 1, dtype=np.int64)
    index = np.empty(total, dtype=np.int64)
    pos = 0
    for c in range(n_cells):
        for j in range(bins):
            bit = np.uint64(1) << np.uint64(j)
            for i in range(cand_start[c], cand_start[c + 1]):
                if marks[i] & bit:
                    index[pos] = cand_idx[i]
                    pos += 1
            start[c * bins + j + 1] = pos
    return start, index


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
def ray_cell(tr: TrackArrays, ox: float, oy: float) -> int:
    """Index (cx * ny + cy) of the ray-grid cell holding (ox, oy), or -1 off the grid."""
    cx = math.floor((ox - tr.ray_origin[0]) / tr.ray_cell)
    cy = math.floor((oy - tr.ray_origin[1]) / tr.ray_cell)
    if cx < 0 or cy < 0 or cx >= tr.ray_shape[0] or cy >= tr.ray_shape[1]:
        return -1
    return cx * tr.ray_shape[1] + cy


@njit(cache=True, inline="always")
def ray_bin(tr: TrackArrays, angle: float) -> int:
    """The direction bin of a ray at ``angle`` [rad] (any angle; it is wrapped)."""
    return ray_bin_scaled((angle + math.pi) * (tr.ray_bins / (2.0 * math.pi)), tr.ray_bins)


@njit(cache=True, inline="always")
def ray_bin_scaled(f: float, bins: int) -> int:
    """The direction bin of a ray whose angle plus pi, times ``bins / (2 pi)``, is ``f`` (no integer division
    when ``f`` is in [-bins, 2 bins), as for rays within pi of a wrapped heading)."""
    j = math.floor(f)
    if j < 0:
        j += bins
    elif j >= bins:
        j -= bins
    if j < 0 or j >= bins:
        j %= bins
    return j


@njit(cache=True, inline="always")
def ray_first_wall(
    walls: np.ndarray,
    index: np.ndarray,
    k0: int,
    k1: int,
    ox: float,
    oy: float,
    dx: float,
    dy: float,
    max_range: float,
) -> float:
    """Distance along the unit ray (dx, dy) from (ox, oy) to the first of the wall segments
    ``walls[index[k0:k1]]`` ([ax, ay, ex, ey] rows) that it hits, capped at ``max_range``.

    The same test as :func:`ray_fan_walls`, one ray at a time: the segment's parameter is tested first (most
    candidates are missed to the side) and the nearest hit so far is kept as the fraction tn / ad, so
    nothing is divided until the end.
    """
    best_tn = max_range
    best_ad = 1.0
    for k in range(k0, k1):
        q = index[k]
        wx = walls[q, 0] - ox
        wy = walls[q, 1] - oy
        ex = walls[q, 2]
        ey = walls[q, 3]
        denom = dx * ey - dy * ex
        sign = 1.0 if denom > 0.0 else -1.0
        un = (wx * dy - wy * dx) * sign
        ad = denom * sign
        if un < 0.0 or un > ad:
            continue
        tn = (wx * ey - wy * ex) * sign
        if tn >= 0.0 and tn * best_ad < best_tn * ad:
            best_tn = tn
            best_ad = ad
    return best_tn / best_ad


@njit(cache=True, inline="always")
def ray_fan_walls(
    tr: TrackArrays, ox: float, oy: float, dxs: np.ndarray, dys: np.ndarray, max_range: float, out: np.ndarray
) -> None:
    """Distances from (ox, oy) along each unit direction (dxs[i], dys[i]) to the first wall, capped at
    ``max_range`` (which must not exceed ``RAY_REACH``), written to ``out``.

    All rays of the fan test the reach list of the origin's cell (exact from any origin; for origins on the
    track, :func:`ray_first_wall` over the cell's direction-bin lists gives the same distances with far fewer
    tests). Segments entirely behind every ray of the fan are skipped; the intersection test uses no
    division until a hit is certain.
    """
    n = dxs.shape[0]
    for i in range(n):
        out[i] = max_range
    c = ray_cell(tr, ox, oy)
    if c < 0:
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
