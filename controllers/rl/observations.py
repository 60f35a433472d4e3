"""The observation of each kart, built for every race of a World at once (spec section 6, "Observation").

One frame per decision, per kart (K karts): own state (9), each opponent (12), the next 5 targets (5 each),
the 9 rays; frames are stacked over the last 4 decisions (newest last). Units are the original's (raw,
speeds over 15 m/s); the trainer normalises them on top (running mean and variance).

* own: v / 15 (signed), accelerating, lane now, lane changes on this stretch / L (the referee's per-step
  counter), active, checkpoints passed this lap / N, current section straight, tyre wear, elapsed time / T;
* opponent: v / 15, accelerating, lane, lane changes / L, active, its section straight, wear, its checkpoints
  this lap / N, distance, position in the ego frame (x forward, y left), heading relative to the ego's / pi;
* target (the next 5 checkpoints): point in the ego frame (x, y), distance, target speed / 15, the section
  ending there straight. The point is the plan's lane point (MCTS-RL: planner waypoints; Fixed-RL: racing-line
  lanes) or, for E2E and lane 0, the checkpoint centre;
* rays: distance / 20 of the 9 rays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from controllers.rl.config import HORIZON, SPEED_SCALE
from sim_core import state as st
from sim_core.track import Track
from sim_core.world import World

OWN_FEATURES = 9
OPPONENT_FEATURES = 12
TARGET_FEATURES = 5
N_RAYS = 9


PHANTOM_GAP = 30.0  # [m] behind the ego: where an absent opponent is shown


def place_phantoms(fstate: np.ndarray, istate: np.ndarray, absent: np.ndarray) -> None:
    """Show the absent karts of each race (``absent``: (R, K) bool, never kart 0) as phantoms, in place: a
    copy of kart 0 (the ego) ``PHANTOM_GAP`` metres behind it along its heading, finished (inactive). The
    race-time tracker shows a missing opponent (a solo race) this way, and training races with absent
    opponents (``EnvConfig.solo_probability``) show them the same, so the policy has seen what it will see."""
    races, slots = np.nonzero(absent)
    if races.size == 0:
        return
    ego_f, ego_i = fstate[races, 0], istate[races, 0]
    fstate[races, slots] = ego_f
    fstate[races, slots, st.F_X] = ego_f[:, st.F_X] - PHANTOM_GAP * np.cos(ego_f[:, st.F_HEADING])
    fstate[races, slots, st.F_Y] = ego_f[:, st.F_Y] - PHANTOM_GAP * np.sin(ego_f[:, st.F_HEADING])
    istate[races, slots] = ego_i
    istate[races, slots, st.I_FINISHED] = 1


def frame_size(n_karts: int) -> int:
    """Floats in one frame for races of ``n_karts`` karts (55 for two)."""
    return OWN_FEATURES + OPPONENT_FEATURES * (n_karts - 1) + TARGET_FEATURES * HORIZON + N_RAYS


@dataclass(frozen=True)
class TrackTables:
    """Per-track constants the builder looks up: target points (N, lanes + 1, 2) with the checkpoint centre at
    index 0 and lane q at index q, lateral offsets the same way (N, lanes + 1), straight flags (N,)."""

    points: np.ndarray
    offsets: np.ndarray
    straight: np.ndarray
    checkpoint_s: np.ndarray
    length: float
    n_checkpoints: int

    @staticmethod
    def of(track: Track) -> TrackTables:
        """The tables of ``track``."""
        n = track.n_checkpoints
        centres = np.array([track.checkpoint_frame(c)[0] for c in range(n)])
        points = np.concatenate([centres[:, None, :], track.lane_points()], axis=1)
        offsets = np.concatenate([np.zeros((n, 1)), np.array([track.lane_offsets(c) for c in range(n)])], axis=1)
        return TrackTables(
            points, offsets, track.straight_flags.astype(float), np.asarray(track.checkpoint_s), track.length, n
        )


def ego_frame(dx: np.ndarray, dy: np.ndarray, heading: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World offsets (dx, dy) rotated into a frame with x along ``heading`` and y to its left."""
    c, s = np.cos(heading), np.sin(heading)
    return c * dx + s * dy, -s * dx + c * dy


def target_indices(world: World, tables: TrackTables) -> np.ndarray:
    """(B, K, HORIZON) checkpoint indices (mod N) of the next targets."""
    passed = world.istate[:, :, st.I_CP_PASSED]
    return np.mod(passed[:, :, None] + 1 + np.arange(HORIZON), tables.n_checkpoints)


def target_points(tables: TrackTables, plan_lane: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """(B, K, H, 2) target points of checkpoints ``idx`` (B, K, H) under the plans' lanes (B, K, N)."""
    lanes = np.take_along_axis(plan_lane, idx, axis=2)
    return tables.points[idx, lanes]


def build_frame(
    world: World,
    tables: TrackTables,
    plan_lane: np.ndarray,
    plan_speed: np.ndarray,
    accelerating: np.ndarray,
    time_fraction: np.ndarray,
) -> np.ndarray:
    """(B, K, frame) the newest observation frame of every kart."""
    f, i = world.fstate, world.istate
    n_races, n_karts = f.shape[:2]
    n = tables.n_checkpoints
    limit = max(world.lane_change_limit, 1)
    speed = f[:, :, st.F_SPEED]
    passed = i[:, :, st.I_CP_PASSED]
    active = 1.0 - i[:, :, st.I_FINISHED]
    straight = tables.straight[np.mod(passed, n)]
    lap_frac = np.mod(passed, n) / n
    lanes = i[:, :, st.I_LANE_NOW].astype(float)
    changes = i[:, :, st.I_STEP_LANE_COUNT] / limit
    wear = f[:, :, st.F_WEAR]
    x, y, heading = f[:, :, st.F_X], f[:, :, st.F_Y], f[:, :, st.F_HEADING]
    parts = [
        np.stack(
            [
                speed / SPEED_SCALE,
                accelerating,
                lanes,
                changes,
                active,
                lap_frac,
                straight,
                wear,
                np.broadcast_to(time_fraction[:, None], speed.shape),
            ],
            axis=-1,
        )
    ]
    for shift in range(1, n_karts):
        j = (np.arange(n_karts) + shift) % n_karts  # the others, in a fixed order per ego
        dx, dy = x[:, j] - x, y[:, j] - y
        fx, fy = ego_frame(dx, dy, heading)
        rel_heading = np.mod(heading[:, j] - heading + np.pi, 2 * np.pi) - np.pi
        parts.append(
            np.stack(
                [
                    speed[:, j] / SPEED_SCALE,
                    accelerating[:, j],
                    lanes[:, j],
                    changes[:, j],
                    active[:, j],
                    straight[:, j],
                    wear[:, j],
                    lap_frac[:, j],
                    np.hypot(dx, dy),
                    fx,
                    fy,
                    rel_heading / np.pi,
                ],
                axis=-1,
            )
        )
    idx = target_indices(world, tables)
    pts = target_points(tables, plan_lane, idx)
    dx, dy = pts[..., 0] - x[:, :, None], pts[..., 1] - y[:, :, None]
    fx, fy = ego_frame(dx, dy, heading[:, :, None])
    tspeed = np.take_along_axis(plan_speed, idx, axis=2) / SPEED_SCALE
    tstraight = tables.straight[np.mod(idx - 1, n)]
    targets = np.stack([fx, fy, np.hypot(dx, dy), tspeed, tstraight], axis=-1)
    parts.append(targets.reshape(n_races, n_karts, -1))
    parts.append(world.ray_dist / world.params.sensors.max_range)
    return np.concatenate(parts, axis=-1)
