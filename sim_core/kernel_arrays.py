"""The arrays the compiled step kernels pass around, bundled in named tuples (numba compiles field access to a
plain load, so a bundle costs nothing over separate arguments), and the compile options of the per-race
kernels.

:class:`TrackArrays` is a track flattened for the kernels (built in :mod:`sim_core.track_arrays`),
:class:`WorldArrays` the world's state (layout in :mod:`sim_core.state`), :class:`StepScratch` the work
arrays of one step, :class:`RayTables` the sensors' angles prepared once per batch call.

This module imports nothing of sim_core's, so every kernel module can name these types at run time.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba import njit

# The per-race kernels run without numba's reference counting: they allocate nothing, and counting the
# references of every array passed to or taken from a namedtuple (atomic updates) was half of a step's time.
NO_REFCOUNT: dict[str, Any] = {"cache": True, "_nrt": False}
# The phases of a step (dynamics, contacts, referee, sensors) live in their own modules but are inlined into
# the step: as separate calls, passing the bundles of arrays by value cost a fifth of a step.
PHASE: dict[str, Any] = {"cache": True, "_nrt": False, "inline": "always"}


class TrackArrays(NamedTuple):
    """A track flattened into arrays for the compiled kernels (built by :func:`sim_core.track_arrays.track_arrays`)."""

    centre_xy: np.ndarray  # (M, 2)
    centre_s: np.ndarray  # (M,)
    seg_tangent: np.ndarray  # (M, 2) unit vector from sample i to sample i+1
    seg_length: np.ndarray  # (M,) distance from sample i to sample i+1
    length: float
    width_left: np.ndarray  # (M,) wall distance
    width_right: np.ndarray  # (M,)
    near_width_left: np.ndarray  # (M,) smallest left wall distance within track_arrays.NEAR_WINDOW
    near_width_right: np.ndarray  # (M,) smallest right wall distance within track_arrays.NEAR_WINDOW
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


class WorldArrays(NamedTuple):
    """The batched world's state: B races x K karts (see :mod:`sim_core.state` for the columns)."""

    F: np.ndarray  # (B, K, N_FLOAT) float state per kart
    I: np.ndarray  # (B, K, N_INT) integer state per kart  # noqa: E741
    R: np.ndarray  # (B, N_RACE) integer state per race
    pair_flags: np.ndarray  # (B, K, K) PAIR_* bits per ordered pair
    target_lane: np.ndarray  # (B, K, N) planned lane per checkpoint (0 = none)
    target_speed: np.ndarray  # (B, K, N) planned speed per checkpoint (NaN = none)
    ray_dist: np.ndarray  # (B, K, rays) [m]
    ray_hit: np.ndarray  # (B, K, rays) HIT_* kind
    pass_start: np.ndarray  # (B, K, K) step + 1 at which i got ahead of j in a pass not yet held (0: none)
    finish_at: np.ndarray  # (B, K) [m] progress at which each kart finishes (NaN: at the line, on its last lap)


class StepScratch(NamedTuple):
    """Work arrays of one race's step, reused across races and steps (no allocation inside the kernels)."""

    prev_s: np.ndarray  # (K,) progress before the step
    prev_d: np.ndarray  # (K,) lateral offset before the step
    heading_before: np.ndarray  # (K,) heading after the dynamics, before contacts
    speed_before: np.ndarray  # (K,) speed after the dynamics, before contacts
    wall_touch: np.ndarray  # (K,) bool: touched a wall this step
    fault_touch: np.ndarray  # (K,) bool: at fault in a new contact this step
    contact: np.ndarray  # (K, K) bool, i < j: touching in any contact round
    first_touch: np.ndarray  # (K, K) bool, i < j: touching in the first contact round
    front: np.ndarray  # (K, K) bool: i's front touches j (first round)
    located: np.ndarray  # (K, 5) [x, y, s, d, sample index] of the last located position
    bodies: np.ndarray  # (K, 6) [cos, sin, rear x, rear y, front x, front y] of every kart's body axis
    fan: np.ndarray  # (3, rays) ray directions x, y and wall distances
    centre: np.ndarray  # (K, 2) [sample index, lateral offset] of every kart for the sensors
    progress: np.ndarray  # (K,) [m] distance driven toward the finish


class RayTables(NamedTuple):
    """The sensors' ray angles prepared for the kernels."""

    cos: np.ndarray  # (rays,) cos of the angle from the heading
    sin: np.ndarray  # (rays,)
    bins: np.ndarray  # (rays,) the angles in ray-grid direction bins


@njit(cache=True)
def make_scratch(n_karts: int, n_rays: int) -> StepScratch:
    """Work arrays for races of ``n_karts`` karts with ``n_rays`` rays each (made inside the compiled batch
    call: passing a bundle of arrays into compiled code costs a conversion per array and call)."""
    K = n_karts
    return StepScratch(
        prev_s=np.empty(K),
        prev_d=np.empty(K),
        heading_before=np.empty(K),
        speed_before=np.empty(K),
        wall_touch=np.zeros(K, dtype=np.bool_),
        fault_touch=np.zeros(K, dtype=np.bool_),
        contact=np.zeros((K, K), dtype=np.bool_),
        first_touch=np.zeros((K, K), dtype=np.bool_),
        front=np.zeros((K, K), dtype=np.bool_),
        located=np.full((K, 5), np.nan),
        bodies=np.empty((K, 6)),
        fan=np.empty((3, n_rays)),
        centre=np.empty((K, 2)),
        progress=np.empty(K),
    )


def scratch_sizes(n_karts: int, n_rays: int) -> tuple[int, int]:
    """(floats, bools) of the buffers :func:`scratch_views` lays a :class:`StepScratch` over."""
    K = n_karts
    return 18 * K + 3 * n_rays, 2 * K + 3 * K * K


@njit(**NO_REFCOUNT)
def scratch_views(floats: np.ndarray, bools: np.ndarray, n_karts: int, n_rays: int) -> StepScratch:
    """A :class:`StepScratch` of views into two buffers the world allocates once (sizes from
    :func:`scratch_sizes`): a batch call then allocates nothing, which is a tenth of a single race's step."""
    K = n_karts
    f = floats
    o = 0
    prev_s, o = f[o : o + K], o + K
    prev_d, o = f[o : o + K], o + K
    heading_before, o = f[o : o + K], o + K
    speed_before, o = f[o : o + K], o + K
    progress, o = f[o : o + K], o + K
    located, o = f[o : o + 5 * K].reshape((K, 5)), o + 5 * K
    bodies, o = f[o : o + 6 * K].reshape((K, 6)), o + 6 * K
    centre, o = f[o : o + 2 * K].reshape((K, 2)), o + 2 * K
    fan = f[o : o + 3 * n_rays].reshape((3, n_rays))
    b = bools
    return StepScratch(
        prev_s=prev_s,
        prev_d=prev_d,
        heading_before=heading_before,
        speed_before=speed_before,
        wall_touch=b[0:K],
        fault_touch=b[K : 2 * K],
        contact=b[2 * K : 2 * K + K * K].reshape((K, K)),
        first_touch=b[2 * K + K * K : 2 * K + 2 * K * K].reshape((K, K)),
        front=b[2 * K + 2 * K * K : 2 * K + 3 * K * K].reshape((K, K)),
        located=located,
        bodies=bodies,
        fan=fan,
        centre=centre,
        progress=progress,
    )
