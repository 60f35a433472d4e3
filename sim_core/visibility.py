"""Exact visibility sweeps behind the ray grid's direction-bin lists: which wall segments a ray from any origin
sampled along a cell's boundary can hit first, with margins for parallax and bin edges."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

RAY_REACH = 20.0  # [m] longest ray the candidate lists serve (the sensors' range)


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
def visible_marks(
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
