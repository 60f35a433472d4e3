"""The ray grid, built offline once per track: per cell of a square grid over the track, every wall segment
within the sensors' reach (exact from any origin), and per cell and direction bin, the few segments that a ray
from the track can hit first (about 3.5 per ray on ``complex`` instead of about 55), found by exact visibility
sweeps (:mod:`sim_core.visibility`)."""

from __future__ import annotations

import hashlib
import math
from typing import NamedTuple

import numpy as np
from numba import njit

from sim_core.geometry import point_segment_distance
from sim_core.visibility import RAY_REACH, visible_marks

RAY_CELL = 2.0  # [m] cell size of the grid that holds each cell's candidate wall segments for ray casts
RAY_BINS = 64  # direction bins of the ray grid's candidate lists (at most 64)
RAY_BIN_MARGIN = math.radians(0.5)  # [rad] a bin's list also serves directions this far outside it ...
RAY_SAMPLE_STEP = 0.1  # [m] ... and origins this far from the ones sampled along its cell's boundary
RAY_PARALLAX_FLOOR = 0.5  # [m] parallax margins are computed as if no end point were nearer than this
RAY_KEEP_NEAR = 0.5  # [m] wall segments this close to a sampled origin are listed in every bin they span


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
    marks = visible_marks(
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
