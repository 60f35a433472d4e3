"""Calibrating the discrete game's time model to the real kart on the real racing line.

The paper's tables (:func:`controllers.tactical.game.build_tables`) time a curve as the turn angle times a
nominal lane radius: the inside lane is always the shortest, and the game's values then contradict the racing
line (an outside-inside-outside path is the fastest way through a corner). Here every lane of a section is
timed on the racing line's own geometry and speed profile, and a kart away from the line pays for it:

* distance: the line's arc length through the section (straights: the lane-to-lane chord, as before);
* cornering speed: the line's slowest speed through the section (an equivalent radius at the race's tyre wear);
* penalty: ``k (d_in^2 + d_out^2) / 2`` for the lateral distances ``d`` of the entry and exit lanes from the
  line (``k`` larger in curves than on straights), plus a lane-change cost per metre of lateral shift.

The same line gives the opponent model: a modelled (line-following) player takes, at each checkpoint, the lane
nearest to the line there (what :class:`~controllers.fixed_line.FixedLinePlanner` targets).
"""

from __future__ import annotations

import math

import numpy as np

from controllers.racing_line import RacingLine
from controllers.tactical.game import TIME_UNITS_PER_S, GameTables
from sim_core.kart import lateral_limit
from sim_core.track import Track

CURVE_OFFLINE_COST = 0.04  # [s/m^2] per curve section, at the mean squared lateral distance from the line
STRAIGHT_OFFLINE_COST = 0.006  # [s/m^2] per straight section
LANE_CHANGE_COST = 0.02  # [s/m] of lateral shift between the section's two checkpoints
REFERENCE_WEAR = 0.25  # tyre wear the equivalent cornering radius is taken at (the race's start)
OPEN_RADIUS = 1.0e4  # [m] a curve the line takes at top speed


def _line_arc(line: RacingLine) -> tuple[np.ndarray, float]:
    """Cumulative arc length [m] of the line at each sample, and the lap's total."""
    steps = np.hypot(*np.diff(np.vstack([line.xy, line.xy[:1]]), axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(steps)[:-1]])
    return arc, float(steps.sum())


def calibrate_tables(tables: GameTables, track: Track, line: RacingLine) -> GameTables:
    """``tables`` with the distance, cornering radius, penalty and predicted-lane tables taken from ``line``."""
    n = track.n_checkpoints
    lanes = track.n_lanes
    arc, arc_total = _line_arc(line)
    s_cp = np.asarray(track.checkpoint_s, dtype=float) % track.length
    arc_cp = np.interp(s_cp, line.s, arc, period=track.length)
    line_offset = np.asarray(line.offset_at(s_cp), dtype=float)
    a_lat = lateral_limit(tables.kart, REFERENCE_WEAR)
    distance = tables.distance.copy()
    radius = np.zeros_like(tables.corner_radius)
    penalty = np.zeros_like(tables.distance)
    for c in range(n):
        nxt = (c + 1) % n
        length = (arc_cp[nxt] - arc_cp[c]) % arc_total
        lo, hi = s_cp[c], s_cp[nxt]
        inside = (line.s >= lo) & (line.s < hi) if hi > lo else (line.s >= lo) | (line.s < hi)
        v_min = float(line.speed[inside].min()) if inside.any() else float(line.speed_at(lo))
        dev_in = tables.lane_offset[c] - line_offset[c]
        dev_out = tables.lane_offset[nxt] - line_offset[nxt]
        straight = bool(tables.straight[c])
        cost = STRAIGHT_OFFLINE_COST if straight else CURVE_OFFLINE_COST
        for i in range(lanes):
            for j in range(lanes):
                shift = abs(tables.lane_offset[c, i] - tables.lane_offset[nxt, j])
                seconds = cost * 0.5 * (dev_in[i] ** 2 + dev_out[j] ** 2) + LANE_CHANGE_COST * shift
                penalty[c, i, j] = seconds * TIME_UNITS_PER_S
                if not straight:
                    distance[c, i, j] = math.hypot(length, 0.0)
                    radius[c, i, j] = OPEN_RADIUS if v_min >= tables.top_speed - 1e-6 else v_min * v_min / a_lat
    predicted = np.array([lane - 1 for lane in line.checkpoint_lanes], dtype=np.int64)
    return tables._replace(distance=distance, corner_radius=radius, penalty=penalty, predicted_lane=predicted)
