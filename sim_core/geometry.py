"""Compiled geometry kernels used at run time: track-frame location, centre-line normals, segment and capsule
distances, angle wrapping.

Everything here is plain arithmetic on float64 scalars and arrays, compiled with numba and safe to call
from other compiled kernels. Angles are radians, counter-clockwise; distances metres."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim_core.kernel_arrays import TrackArrays


# --------------------------------------------------------------------------- scalar helpers
@njit(cache=True, inline="always")
def wrap_angle(a: float) -> float:
    """Angle wrapped to [-pi, pi) (no library call when it already lies there)."""
    w = a + math.pi
    if not 0.0 < w < 2.0 * math.pi:
        w %= 2.0 * math.pi
    return w - math.pi


@njit(cache=True, inline="always")
def wrap_mod(x: float, m: float) -> float:
    """``x % m`` (m > 0), without the library call when x already lies in (0, m)."""
    if 0.0 < x < m:
        return x
    return x % m


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
def body_axes(b: int, F: np.ndarray, hl: float, body: np.ndarray) -> None:
    """Every kart's heading cos and sin and body axis end points: body[k] = [cos, sin, rear x, rear y,
    front x, front y]."""
    for k in range(F.shape[1]):
        x, y = F[b, k, 0], F[b, k, 1]
        h = F[b, k, 2]
        c, s = math.cos(h), math.sin(h)
        body[k, 0] = c
        body[k, 1] = s
        body[k, 2] = x - hl * c
        body[k, 3] = y - hl * s
        body[k, 4] = x + hl * c
        body[k, 5] = y + hl * s
