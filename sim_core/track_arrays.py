"""Tracks flattened into arrays for the compiled kernels: centre line, walls, checkpoints and lanes, and the
ray grid (:mod:`sim_core.ray_grid`) the sensors read."""

from __future__ import annotations

import hashlib

import numpy as np

from sim_core.kernel_arrays import TrackArrays
from sim_core.ray_grid import RAY_BINS, RAY_CELL, ray_grid
from sim_core.track import Track

WALL_SIMPLIFY_TOLERANCE = 0.02  # [m] wall polyline points closer than this to a straight chord are merged


WALL_MAX_SEGMENT = 40.0  # [m] merged wall segments are kept at most this long


NEAR_WINDOW = 2.5  # [m] along-track reach of the near_width_* minima (more than half a kart's length)


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


_ARRAYS: dict[bytes, TrackArrays] = {}


def track_fingerprint(track: Track) -> bytes:
    """A digest of everything :func:`track_arrays` reads of ``track``: two tracks with one fingerprint have the
    same arrays (a track loaded twice from one file, or a race's and its planner's copy)."""
    digest = hashlib.blake2b(digest_size=20)
    digest.update(repr((track.name, track.length, track.lane_fractions, track.checkpoints, track.sections)).encode())
    for array in (track.centre_xy, track.centre_s, track.width_left, track.width_right, track.checkpoint_s):
        digest.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
    for array in (track.lane_half_left, track.lane_half_right, track.straight_flags):
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.digest()


def shared_track_arrays(track: Track) -> TrackArrays:
    """:func:`track_arrays`, built once per process for each track (its ray grid costs a tenth of a second, and
    a tournament builds a world per chunk of races). The arrays are shared: no kernel writes to them."""
    key = track_fingerprint(track)
    arrays = _ARRAYS.get(key)
    if arrays is None:
        arrays = _ARRAYS[key] = track_arrays(track)
    return arrays


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
