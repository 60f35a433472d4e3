"""The discrete racing game of the tactical planner (paper section 4.1), as flat arrays for compiled search.

A player's state at a checkpoint is (checkpoint, lane, velocity bin, time in 0.01 s, tyre wear in 1e-4,
recent lane-change count). An action picks the lane and velocity bin at the next checkpoint; the time to
get there comes from the 1-D motion model (:mod:`controllers.tactical.motion`) under the kart's
acceleration and braking limits and the cornering speed of the lane's radius at the current wear.

This module builds the per-track tables (:class:`GameTables`) that the compiled rules read.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from sim_core.params import KartParams
from sim_core.track import Track

TIME_UNITS_PER_S = 100  # time states are integers in 0.01 s
WEAR_UNITS = 10_000  # tyre wear states are integers in 1e-4
MAX_SCRIPTS = 8  # players of one game whose lanes an opponent model scripts per checkpoint (the most karts in a race)


@dataclass(frozen=True)
class GameParams:
    """Settings of the discrete game."""

    velocity_bin_width: float = 1.0  # [m/s] width of the velocity bins (1 or 2 in the paper's runs)
    min_speed: float = 6.0  # [m/s] lowest bin starts here
    horizon: int = 8  # checkpoints ahead
    collision_window: float = 0.1  # [s] same lane at the same checkpoint closer than this is ruled out
    # [m] two karts' centres closer than this along the track, and laterally closer than ``lateral_clearance``,
    # anywhere along a section (sampled) is a collision: a kart length (2 m) plus a margin; 0 disables it
    collision_distance: float = 3.0
    lateral_clearance: float = 1.5  # [m] a kart width (0.9 m) plus a margin
    # [m] a kart still to move (behind in time) constrains the one moving first only when this close along the
    # track (alongside, overlapping): the leader need not yield to a follower, who must keep its distance
    alongside_distance: float = 2.0
    collision_pruning: bool = True  # the paper's rule (the original had it switched off)
    value_scale: float = 1.0  # [s] time advantage that maps to a value of 1 (0.5 = level)
    section_window: int = 2  # opponents fewer than this many checkpoints away are players in the game

    def __post_init__(self) -> None:
        if self.velocity_bin_width <= 0:
            raise ValueError("velocity_bin_width must be > 0")
        if self.horizon < 1:
            raise ValueError("horizon must be >= 1")


class GameTables(NamedTuple):
    """Per-track, per-kart constants of the game, flattened for the compiled rules.

    Indexing: ``c`` is a checkpoint (mod N); section ``c`` is the road from checkpoint c to c + 1;
    lanes are 0-based here (lane id - 1); bins are 0-based.
    """

    distance: np.ndarray  # (N, lanes, lanes) [m] from lane i at c to lane j at c + 1
    corner_radius: np.ndarray  # (N, lanes, lanes) [m] mean lane radius through section c (0 = straight)
    turn_angle: np.ndarray  # (N,) [rad] heading change of section c (0 on straights)
    straight: np.ndarray  # (N,) bool
    bin_low: np.ndarray  # (bins,) [m/s]
    bin_high: np.ndarray  # (bins,) [m/s]
    lane_limit: int  # L
    top_speed: float  # [m/s]
    accel: float  # [m/s^2]
    brake: float  # [m/s^2]
    kart: np.ndarray  # the kart's packed parameters: its own grip and tyre-wear model (sim_core.kart)
    collision_window: int  # [0.01 s]; 0 disables collision pruning
    value_scale: float  # [0.01 s]
    penalty: np.ndarray  # (N, lanes, lanes) [0.01 s] time added to a section (off the racing line, lane changes)
    lane_offset: np.ndarray  # (N, lanes) [m] left-positive lateral offsets of the lanes at each checkpoint
    predicted_lane: np.ndarray  # (N,) 0-based lane a modelled (line-following) player takes at checkpoint c; -1 none
    scripted_lane: np.ndarray  # (MAX_SCRIPTS, N) 0-based lane of each scripted player at checkpoint c; -1 none
    collision_distance: float  # [m] 0 disables the along-the-section check
    lateral_clearance: float  # [m]
    alongside_distance: float  # [m]


def velocity_bins(params: GameParams, top_speed: float) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) edges [m/s] of the velocity bins: from ``min_speed`` up to top speed."""
    lows = []
    low = params.min_speed
    while low < top_speed - 1e-9:
        lows.append(low)
        low += params.velocity_bin_width
    lo = np.array(lows)
    return lo, np.minimum(lo + params.velocity_bin_width, top_speed)


def build_tables(track: Track, kart: KartParams, params: GameParams, lane_limit: int | None = None) -> GameTables:
    """The game's tables for ``track`` and ``kart``.

    Straight sections: the distance between lane points is the straight length with the lateral shift of
    the actual lane offsets (not the original's W/3 per lane). Curves: the turn angle times the mean of the
    two lanes' nominal radii (lanes spread evenly from the inside radius, as the original).
    """
    n = track.n_checkpoints
    lanes = track.n_lanes
    width = track.nominal_width
    distance = np.zeros((n, lanes, lanes))
    radius = np.zeros((n, lanes, lanes))
    angle = np.zeros(n)
    for c, section in enumerate(track.sections):
        here = track.lane_offsets(c)
        there = track.lane_offsets(c + 1)
        if section.is_straight:
            for i in range(lanes):
                for j in range(lanes):
                    distance[c, i, j] = np.hypot(section.length, here[i] - there[j])
        else:
            angle[c] = np.deg2rad(section.angle_deg)
            for i in range(lanes):
                for j in range(lanes):
                    r = 0.5 * (section.lane_radius(i + 1, lanes, width) + section.lane_radius(j + 1, lanes, width))
                    radius[c, i, j] = r
                    distance[c, i, j] = angle[c] * r
    low, high = velocity_bins(params, kart.top_speed)
    return GameTables(
        distance=distance,
        corner_radius=radius,
        turn_angle=angle,
        straight=track.straight_flags.copy(),
        bin_low=low,
        bin_high=high,
        lane_limit=int(track.lane_change_limit if lane_limit is None else lane_limit),
        top_speed=kart.top_speed,
        accel=kart.acceleration,
        brake=kart.braking,
        kart=kart.as_array(),
        collision_window=round(params.collision_window * TIME_UNITS_PER_S) if params.collision_pruning else 0,
        value_scale=params.value_scale * TIME_UNITS_PER_S,
        penalty=np.zeros((n, lanes, lanes)),
        lane_offset=np.array([track.lane_offsets(c) for c in range(n)], dtype=float),
        predicted_lane=np.full(n, -1, dtype=np.int64),
        scripted_lane=np.full((MAX_SCRIPTS, n), -1, dtype=np.int64),
        collision_distance=float(params.collision_distance) if params.collision_pruning else 0.0,
        lateral_clearance=float(params.lateral_clearance),
        alongside_distance=float(params.alongside_distance),
    )
