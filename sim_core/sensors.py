"""The range sensors: ray casts against walls (through the ray grid, :mod:`sim_core.ray_grid`) and karts'
capsules. ``ray_walls`` tests every wall segment and is the oracle for the grid-accelerated casts."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim_core.geometry import body_axes, locate
from sim_core.kart import P_HALF_LENGTH, P_RADIUS
from sim_core.kernel_arrays import NO_REFCOUNT, RayTables, StepScratch, TrackArrays, WorldArrays, make_scratch
from sim_core.state import (
    F_HEADING,
    F_X,
    F_Y,
    HIT_KART,
    HIT_NONE,
    HIT_WALL,
    I_CENTRE_IDX,
    I_FINISHED,
    RP_RAY_ORIGIN,
    RP_RAY_RANGE,
)

ORIGIN_TRACK_MARGIN = 0.1  # [m] sensor origins this far inside the walls' nominal offsets use the bin lists


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


@njit(**NO_REFCOUNT)
def cast_rays(
    b: int,
    w: WorldArrays,
    tr: TrackArrays,
    kp: np.ndarray,
    rp: np.ndarray,
    rays: RayTables,
    scratch: StepScratch,
) -> None:
    """The range rays of every kart in race ``b`` (at the angles of ``rays``): distance to the first wall or
    kart, and what it hit. ``scratch.bodies`` holds the karts' bodies (see :func:`sim_core.geometry.body_axes`) and
    ``scratch.centre`` their located [sample index, lateral offset].

    A sensor origin clearly between the walls (by the kart's lateral offset) tests each
    ray against its cell's list for the ray's direction bin; any other origin tests the cell's whole reach
    list, as :func:`ray_fan_walls` does. Both give the distance to the first wall.
    """
    K = w.F.shape[1]
    hl = kp[P_HALF_LENGTH]
    r = kp[P_RADIUS]
    max_range = rp[RP_RAY_RANGE]
    origin = rp[RP_RAY_ORIGIN]
    n_rays = rays.cos.shape[0]
    ray_cos, ray_sin, ray_bins = rays.cos, rays.sin, rays.bins
    walls = tr.wall_segments
    index = tr.ray_bin_index
    start = tr.ray_bin_start
    bins = tr.ray_bins
    bin_scale = bins / (2.0 * math.pi)
    inside = abs(origin) + ORIGIN_TRACK_MARGIN
    body = scratch.bodies
    dxs = scratch.fan[0]
    dys = scratch.fan[1]
    wall = scratch.fan[2]
    F, I = w.F, w.I
    ray_dist, ray_hit = w.ray_dist, w.ray_hit
    for k in range(K):
        ch, sh = body[k, 0], body[k, 1]
        ox = F[b, k, F_X] + origin * ch
        oy = F[b, k, F_Y] + origin * sh
        for a in range(n_rays):
            dxs[a] = ch * ray_cos[a] - sh * ray_sin[a]
            dys[a] = sh * ray_cos[a] + ch * ray_sin[a]
        cell = ray_cell(tr, ox, oy)
        idx, d = int(scratch.centre[k, 0]), scratch.centre[k, 1]
        if cell >= 0 and d + inside < tr.near_width_left[idx] and inside - d < tr.near_width_right[idx]:
            # on the track: one short list per ray
            heading_bin = (F[b, k, F_HEADING] + math.pi) * bin_scale
            base = cell * bins
            for a in range(n_rays):
                slot = base + ray_bin_scaled(heading_bin + ray_bins[a], bins)
                wall[a] = ray_first_wall(walls, index, start[slot], start[slot + 1], ox, oy, dxs[a], dys[a], max_range)
        else:
            ray_fan_walls(tr, ox, oy, dxs, dys, max_range, wall)
        for a in range(n_rays):
            dx, dy = dxs[a], dys[a]
            dist = wall[a]
            kind = HIT_WALL if dist < max_range else HIT_NONE
            for j in range(K):
                if j == k or I[b, j, I_FINISHED]:
                    continue
                rel_x, rel_y = F[b, j, F_X] - ox, F[b, j, F_Y] - oy
                along = rel_x * dx + rel_y * dy
                if along < -(hl + r) or along > dist + hl + r or abs(rel_x * dy - rel_y * dx) > hl + r:
                    continue
                t = ray_capsule(ox, oy, dx, dy, body[j, 2], body[j, 3], body[j, 4], body[j, 5], r)
                if t < dist:
                    dist, kind = t, HIT_KART
            ray_dist[b, k, a] = dist
            ray_hit[b, k, a] = kind


@njit(cache=True)
def prepare_rays(ray_angles: np.ndarray, grid_bins: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """cos, sin and ray-grid direction-bin offsets of the sensors' angles (fields of :class:`RayTables`)."""
    ray_bins = (ray_angles + math.pi) % (2.0 * math.pi) - math.pi  # the bin offsets of the ray angles
    ray_bins *= grid_bins / (2.0 * math.pi)
    return np.cos(ray_angles), np.sin(ray_angles), ray_bins


@njit(cache=True)
def sense_batch(
    F: np.ndarray,
    I: np.ndarray,
    ray_dist: np.ndarray,
    ray_hit: np.ndarray,
    tr: TrackArrays,
    kp: np.ndarray,
    rp: np.ndarray,
    ray_angles: np.ndarray,
) -> None:
    """Cast every kart's rays (used after a reset, before the first step)."""
    empty = np.zeros((0, 0, 0), dtype=np.int64)  # the sensors read no other state
    w = WorldArrays(F, I, empty, empty, empty, np.zeros((0, 0, 0)), ray_dist, ray_hit, empty, np.zeros((0, 0)))
    cos, sin, bins = prepare_rays(ray_angles, tr.ray_bins)
    rays = RayTables(cos, sin, bins)
    scratch = make_scratch(F.shape[1], ray_angles.shape[0])
    for b in range(F.shape[0]):
        for k in range(F.shape[1]):
            idx, _s, d = locate(tr, F[b, k, F_X], F[b, k, F_Y], I[b, k, I_CENTRE_IDX])
            scratch.centre[k, 0] = idx
            scratch.centre[k, 1] = d
        body_axes(b, F, kp[P_HALF_LENGTH], scratch.bodies)
        cast_rays(b, w, tr, kp, rp, rays, scratch)
