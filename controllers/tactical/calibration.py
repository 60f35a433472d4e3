"""Calibrating the discrete game's time model to the real kart on the real racing line.

The paper's tables (:func:`controllers.tactical.game.build_tables`) time a curve as the turn angle times a
nominal lane radius: the inside lane is always the shortest, and the game's values then contradict the racing
line (an outside-inside-outside path is the fastest way through a corner). Here every lane of a section is
timed on the racing line's own geometry and speed profile, and a kart away from the line pays for it:

* distance: the line's arc length through the section (straights: the lane-to-lane chord, as before);
* cornering speed: the line's slowest speed through the section (an equivalent radius at the race's tyre wear);
* penalty: the mean of the section's extra time on the line shifted sideways by the entry lane's and by the
  exit lane's distance ``d`` from the line (the same speed-profile model as the line's own,
  :func:`controllers.racing_line.speed_profile`: a shifted path is tighter on the inside of a corner and
  wider on the outside), plus a lane-change cost per metre the lateral distance from the line changes.

The same line gives the opponent model: a modelled (line-following) player takes, at each checkpoint, the lane
nearest to the line there (what :class:`~controllers.fixed_line.FixedLinePlanner` targets).
"""

from __future__ import annotations

import math

import numpy as np

from controllers.racing_line import REFERENCE_WEAR, RacingLine, shifted_lines
from controllers.tactical.game import TIME_UNITS_PER_S, GameTables
from sim_core.kart import lateral_limit
from sim_core.params import KartParams
from sim_core.track import Track


def section_times(xy: np.ndarray, speed: np.ndarray, sample_section: np.ndarray, n: int) -> np.ndarray:
    """(n,) time [s] a closed path of samples spends in each section at the given speed profile."""
    ds = np.hypot(*(np.roll(xy, -1, axis=0) - xy).T)
    dt = 2.0 * ds / np.maximum(speed + np.roll(speed, -1), 1e-6)
    return np.bincount(sample_section, weights=dt, minlength=n)


def line_sample_sections(track: Track, line: RacingLine) -> np.ndarray:
    """(M,) the section (checkpoint c to c + 1) each sample of ``line`` lies in."""
    s_cp = np.asarray(track.checkpoint_s, dtype=float) % track.length
    return (np.searchsorted(s_cp, line.s, side="right") - 1) % track.n_checkpoints


def shifted_line_times(track: Track, line: RacingLine, kart: KartParams) -> tuple[np.ndarray, np.ndarray]:
    """(shifts, times): each section's time (len(shifts), N) on the line moved sideways by each shift [m]
    (:func:`~controllers.racing_line.shifted_lines`, at its reference tyre wear)."""
    paths = shifted_lines(track, line, kart)
    n = track.n_checkpoints
    sample_section = line_sample_sections(track, line)
    times = np.array([section_times(xy, speed, sample_section, n) for xy, speed in zip(paths.xy, paths.speed)])
    return paths.shifts, times


# the tracker drives an off-line lane as kinked blends between lane points, not as a smooth shifted line: the
# shifted line's extra time, times this, is what a lane off the line costs in a race
TRACKING_FACTOR = 2.0
# change of the lateral distance from the line between the section's checkpoints: [s/m] and [s/m^2] (a large
# shift within one section needs more lateral grip than the kart has to spare, so it costs more than linearly)
LANE_CHANGE_COST = 0.02
LANE_CHANGE_COST_SQ = 0.01
MIN_PENALTY = -0.1  # [s] a shifted line is never credited more than this on one section
OPEN_RADIUS = 1.0e4  # [m] a curve the line takes at top speed


def _line_arc(line: RacingLine) -> tuple[np.ndarray, float]:
    """Cumulative arc length [m] of the line at each sample, and the lap's total."""
    steps = np.hypot(*np.diff(np.vstack([line.xy, line.xy[:1]]), axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(steps)[:-1]])
    return arc, float(steps.sum())


def calibrate_tables(tables: GameTables, track: Track, line: RacingLine, kart: KartParams) -> GameTables:
    """``tables`` with the distance, cornering radius, penalty and predicted-lane tables taken from ``line``."""
    shifts, times = shifted_line_times(track, line, kart)
    on_line = np.array([np.interp(0.0, shifts, times[:, c]) for c in range(track.n_checkpoints)])
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
        extra_in = np.interp(dev_in, shifts, times[:, c]) - on_line[c]
        extra_out = np.interp(dev_out, shifts, times[:, c]) - on_line[c]
        for i in range(lanes):
            for j in range(lanes):
                change = abs(dev_out[j] - dev_in[i])
                offline = TRACKING_FACTOR * 0.5 * (extra_in[i] + extra_out[j])
                seconds = max(offline, MIN_PENALTY) + LANE_CHANGE_COST * change + LANE_CHANGE_COST_SQ * change**2
                penalty[c, i, j] = seconds * TIME_UNITS_PER_S
                if not straight:
                    distance[c, i, j] = math.hypot(length, 0.0)
                    radius[c, i, j] = OPEN_RADIUS if v_min >= tables.top_speed - 1e-6 else v_min * v_min / a_lat
    predicted = np.array([lane - 1 for lane in line.checkpoint_lanes], dtype=np.int64)
    return tables._replace(distance=distance, corner_radius=radius, penalty=penalty, predicted_lane=predicted)
