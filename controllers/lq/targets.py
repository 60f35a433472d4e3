"""The LQNG tracker's per-step arithmetic, compiled: every player's pure-pursuit aim, heading error and speed
target (:func:`player_targets`), and the game's weights and solution from them (:func:`solve_targets`).

:class:`controllers.lq.tracker.LQNGTracker` decides which waypoints each player drives for and what its traffic
rules allow; these kernels do the arithmetic it did in Python, in the same order on the same numbers, so a race is
the same to the last bit (``math.hypot`` and ``math.remainder`` as CPython computes them:
:mod:`sim_core.exact_math`). Python's ``min`` / ``max`` keep the first of equal values; so do :func:`_least` and
:func:`_most`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from controllers.lq.game import STATE_SIZE, solve_tracker_game
from controllers.racing_line import RacingLine
from sim_core.exact_math import py_hypot, py_remainder
from sim_core.track import Track

# columns of a player row
PX, PY, PHEADING, PSPEED, PPROGRESS, PLATERAL = range(6)
PLAYER_COLUMNS = 6
# columns of a waypoint row: checkpoint, lane (1-based), x, y, planned speed
WCHECKPOINT, WLANE, WX, WY, WSPEED = range(5)
WAYPOINT_COLUMNS = 5
# columns of a target row (player_targets' answer)
AIM_OFFSET, HEADING_ERROR, SPEED_TARGET = range(3)


@dataclass(frozen=True)
class TrackerTables:
    """The track's and racing line's numbers the kernels look up, as arrays of the very floats the Python
    lookups used."""

    length: float  # [m] the track's lap
    checkpoint_s: np.ndarray  # (C,) [m]
    lane_offsets: np.ndarray  # (C, L) [m] lane l + 1's offset at each checkpoint (padded with NaN)
    segment_starts: np.ndarray  # (M,) [m] the centre line's segments (Track.segments)
    segment_ends: np.ndarray  # (M,)
    segment_deltas: np.ndarray  # (M, 2)
    segment_tangents: np.ndarray  # (M, 2)
    centre_xy: np.ndarray  # (M, 2)
    line_length: float  # [m] the racing line's closed length
    line_s: np.ndarray  # (K + 1,) [m] the line's samples, closed
    line_offset: np.ndarray  # (K + 1,) its offsets and each segment's slope (K,)
    line_offset_slope: np.ndarray
    line_speed: np.ndarray  # (K + 1,) its speed profile and slopes (K,)
    line_speed_slope: np.ndarray

    @classmethod
    def of(cls, track: Track, line: RacingLine) -> TrackerTables:
        """The tables of ``track`` and its racing line ``line``."""
        offsets = [track.lane_offsets(c) for c in range(track.n_checkpoints)]
        lanes = np.full((track.n_checkpoints, max(len(o) for o in offsets)), np.nan)
        for c, o in enumerate(offsets):
            lanes[c, : len(o)] = o
        starts, ends, deltas, tangents = track.segments
        s, (offset, offset_slope), (speed, speed_slope) = line.interpolation_tables
        # every table a fresh writable C-contiguous float64 copy: numba compiles one kernel per argument type, and
        # a track's cached arrays are read-only where they were computed but writable where the track was
        # unpickled (a controller host): without the copy each such process compiled the tracker's kernels anew,
        # mid-race, for seconds
        return cls(
            float(track.length),
            _table(track.checkpoint_s),
            _table(lanes),
            _table(starts),
            _table(ends),
            _table(deltas),
            _table(tangents),
            _table(track.centre_xy),
            float(line.closed_length),
            _table(s),
            _table(offset),
            _table(offset_slope),
            _table(speed),
            _table(speed_slope),
        )


def _table(values: Any) -> np.ndarray:
    """A fresh writable C-contiguous float64 copy of ``values``."""
    return np.array(values, dtype=np.float64)


@njit(cache=True, inline="always")
def _least(a: float, b: float) -> float:
    return b if b < a else a


@njit(cache=True, inline="always")
def _most(a: float, b: float) -> float:
    return b if b > a else a


@njit(cache=True)
def interpolate(x: float, xs: np.ndarray, ys: np.ndarray, slopes: np.ndarray) -> float:
    """``np.interp(x, xs, ys)`` for one point, as numpy computes it (``RacingLine``'s one-point lookups)."""
    j = np.searchsorted(xs, x, side="right") - 1
    if j < 0:
        return ys[0]
    if j >= xs.shape[0] - 1 or xs[j] == x:
        return ys[j]
    return slopes[j] * (x - xs[j]) + ys[j]


@njit(cache=True)
def _line_offset(s: float, line_length: float, line_s: np.ndarray, offset: np.ndarray, slope: np.ndarray) -> float:
    return interpolate(s % line_length, line_s, offset, slope)


@njit(cache=True)
def _lane_correction(lane_offset: float, line_offset: float, tolerance: float) -> float:
    gap = lane_offset - line_offset
    return 0.0 if abs(gap) <= tolerance else gap - math.copysign(tolerance, gap)


@njit(cache=True)
def player_targets(
    players: np.ndarray,
    waypoints: np.ndarray,
    tolerance: float,
    ego_bounds: np.ndarray,
    min_lookahead: float,
    lookahead_time: float,
    top_speed: float,
    braking: float,
    braking_use: float,
    speed_margin: float,
    length: float,
    checkpoint_s: np.ndarray,
    lane_offsets: np.ndarray,
    segment_starts: np.ndarray,
    segment_ends: np.ndarray,
    segment_deltas: np.ndarray,
    segment_tangents: np.ndarray,
    centre_xy: np.ndarray,
    line_length: float,
    line_s: np.ndarray,
    line_offset: np.ndarray,
    line_offset_slope: np.ndarray,
    line_speed: np.ndarray,
    line_speed_slope: np.ndarray,
) -> np.ndarray:
    """(n, 3) per player (``players`` rows, the ego first; its next two waypoints ``waypoints[i]``): the lateral
    offset of its aim point, its heading error to the aim and its speed target (before the ego's speed scale and
    limits). The aim is on the racing line's shape shifted by the waypoints' lanes' offsets from it beyond
    ``tolerance``, the ego's held within ``ego_bounds`` (lowest, highest)."""
    n = players.shape[0]
    out = np.empty((n, 3))
    n_checkpoints = checkpoint_s.shape[0]
    for i in range(n):
        x, y, heading = players[i, PX], players[i, PY], players[i, PHEADING]
        speed, progress, lateral = players[i, PSPEED], players[i, PPROGRESS], players[i, PLATERAL]
        first, second = waypoints[i, 0], waypoints[i, 1]
        # pure pursuit (LQNGTracker's aim)
        lookahead = _most(min_lookahead, abs(speed) * lookahead_time)
        at1, at2 = int(first[WCHECKPOINT]) % n_checkpoints, int(second[WCHECKPOINT]) % n_checkpoints
        s1 = (checkpoint_s[at1] - progress) % length
        s2 = s1 + (checkpoint_s[at2] - checkpoint_s[at1]) % length
        d1 = lane_offsets[at1, int(first[WLANE]) - 1]
        d2 = lane_offsets[at2, int(second[WLANE]) - 1]
        aim_s = progress + lookahead
        c1 = _lane_correction(
            d1, _line_offset(progress + s1, line_length, line_s, line_offset, line_offset_slope), tolerance
        )
        c2 = _lane_correction(
            d2, _line_offset(progress + s2, line_length, line_s, line_offset, line_offset_slope), tolerance
        )
        c_now = lateral - _line_offset(progress, line_length, line_s, line_offset, line_offset_slope)
        if lookahead <= s1:
            correction = c_now + (c1 - c_now) * lookahead / _most(s1, 1e-6)
        else:
            correction = c1 + (c2 - c1) * _least((lookahead - s1) / _most(s2 - s1, 1e-6), 1.0)
        d = _line_offset(aim_s, line_length, line_s, line_offset, line_offset_slope) + correction
        if i == 0:
            d = _least(_most(d, ego_bounds[0]), ego_bounds[1])
        # the centre line's point and tangent at aim_s (Track.point_at)
        s = aim_s % length
        k = np.searchsorted(segment_starts, s, side="right") - 1
        u = (s - segment_starts[k]) / _most(segment_ends[k] - segment_starts[k], 1e-12)
        point_x = centre_xy[k, 0] + u * segment_deltas[k, 0]
        point_y = centre_xy[k, 1] + u * segment_deltas[k, 1]
        aim_x = point_x - segment_tangents[k, 1] * d
        aim_y = point_y + segment_tangents[k, 0] * d
        # the speed target: never over the line's profile here, and slow enough for each waypoint's speed
        target = _least(top_speed, interpolate(progress % line_length, line_s, line_speed, line_speed_slope))
        for w in (first, second):
            dist = py_hypot(w[WX] - x, w[WY] - y)
            planned = _least(w[WSPEED] + speed_margin, top_speed)
            target = _least(target, math.sqrt(planned**2 + 2.0 * braking * braking_use * dist))
        out[i, AIM_OFFSET] = d
        out[i, HEADING_ERROR] = py_remainder(math.atan2(aim_y - y, aim_x - x) - heading, 2.0 * math.pi)
        out[i, SPEED_TARGET] = target
    return out


@njit(cache=True)
def solve_targets(
    players: np.ndarray,
    targets: np.ndarray,
    denied: np.ndarray,
    position_weight: float,
    speed_weight: float,
    heading_weight: float,
    avoid_scale: float,
    opponent_avoid_scale: float,
    deny: float,
    control_weight: float,
    dt: float,
    horizon: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The game of :func:`controllers.lq.game.solve_tracker_game` for ``players`` (rows, the ego first) toward
    ``targets`` (psi_x, psi_y, psi_v, psi_theta per player): each player's position weight over its speed, the
    separation weights from the distances (eq. (22)), the ego's denial weight (eq. (21)) over its speed; its
    gains ``P``, ``alpha`` and the game's state ``x0`` (positions relative to the ego)."""
    n = players.shape[0]
    separation = np.zeros((n, n))
    position_weights = np.empty(n)
    x0 = np.zeros(STATE_SIZE * n)
    ego_x, ego_y = players[0, PX], players[0, PY]
    for i in range(n):
        scale = avoid_scale if i == 0 else opponent_avoid_scale
        for j in range(n):
            if j != i:
                dist = _most(py_hypot(players[j, PX] - players[i, PX], players[j, PY] - players[i, PY]), 0.5)
                separation[i, j] = 1.0 / (dist**1.5 * scale)
        position_weights[i] = position_weight / _most(1.0, players[i, PSPEED])
        x0[STATE_SIZE * i] = players[i, PX] - ego_x
        x0[STATE_SIZE * i + 1] = players[i, PY] - ego_y
        x0[STATE_SIZE * i + 2] = players[i, PSPEED]
    P, alpha = solve_tracker_game(
        players[:, PHEADING].copy(),
        players[:, PSPEED].copy(),
        targets,
        position_weights,
        speed_weight,
        heading_weight,
        separation,
        denied,
        deny / _most(1.0, players[0, PSPEED]),
        control_weight,
        dt,
        horizon,
    )
    return P, alpha, x0
