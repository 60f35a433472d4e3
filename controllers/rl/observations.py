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
from numba import njit

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


def race_karts(obs_size: int, stack: int) -> int | None:
    """The karts per race (1 to 8) whose stacked observation has ``obs_size`` floats, or ``None``."""
    return {stack * frame_size(m): m for m in range(1, 9)}.get(obs_size)


def widened_columns(karts_from: int, karts_to: int, stack: int) -> tuple[np.ndarray, np.ndarray]:
    """How a stacked observation of races of ``karts_from`` karts maps into one of ``karts_to`` karts (more
    opponents): for each column of the wide observation, the narrow column it corresponds to, and whether it is
    an added opponent's (then it copies the statistics of the first opponent's column of the same feature).

    A policy widened this way (the added columns weighted zero, :func:`controllers.rl.train.load_actor`) acts
    as the narrow one did, up to rounding, whatever the added opponents' features: the start of training it
    in fields without forgetting how to drive."""
    if not 2 <= karts_from <= karts_to:
        raise ValueError(f"can widen from 2 or more karts to as many or more, not {karts_from} to {karts_to}")
    narrow = frame_size(karts_from)
    kept = OWN_FEATURES + OPPONENT_FEATURES * (karts_from - 1)  # own features and the opponents it had
    first_opponent = np.arange(OWN_FEATURES, OWN_FEATURES + OPPONENT_FEATURES)
    added = np.tile(first_opponent, karts_to - karts_from)
    frame = np.concatenate([np.arange(kept), added, np.arange(kept, narrow)])  # targets and rays last
    frame_added = np.concatenate([np.zeros(kept, bool), np.ones(added.size, bool), np.zeros(narrow - kept, bool)])
    source = np.concatenate([frame + f * narrow for f in range(stack)])
    return source, np.tile(frame_added, stack)


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
    speed_unit: float = SPEED_SCALE,
) -> np.ndarray:
    """(B, K, frame) the newest observation frame of every kart, speeds in ``speed_unit`` (the trained one, or
    for a kart at a pace handicap that times its pace: the kart then sees its own time, in which it drives as
    the trained kart, :meth:`sim_core.params.KartParams.paced`).

    ``world`` needs only ``fstate``, ``istate``, ``ray_dist``, ``lane_change_limit`` and
    ``params.sensors.max_range`` (the race-time tracker passes a one-race stand-in)."""
    f, i = world.fstate, world.istate
    out = np.empty((f.shape[0], f.shape[1], frame_size(f.shape[1])))
    _fill_frames(
        f,
        i,
        world.ray_dist,
        float(world.params.sensors.max_range),
        max(int(world.lane_change_limit), 1),
        tables.points,
        tables.straight,
        np.asarray(plan_lane, dtype=np.int64),
        np.asarray(plan_speed, dtype=np.float64),
        np.asarray(accelerating, dtype=np.float64),
        np.asarray(time_fraction, dtype=np.float64),
        float(speed_unit),
        out,
    )
    return out


# One compiled loop instead of ~60 numpy calls per World: the training batch builds a frame per track per
# decision for about 20 races each, where numpy's per-call overhead was most of the environment's step. The
# arithmetic is numpy's, operation by operation (same order, libm's cos/sin/hypot, no fused multiply-add), so
# the frames are bit-identical to the array version this replaced.
@njit(cache=True)
def _fill_frames(
    f: np.ndarray,
    i: np.ndarray,
    ray_dist: np.ndarray,
    max_range: float,
    limit: int,
    points: np.ndarray,
    straight: np.ndarray,
    plan_lane: np.ndarray,
    plan_speed: np.ndarray,
    accelerating: np.ndarray,
    time_fraction: np.ndarray,
    speed_unit: float,
    out: np.ndarray,
) -> None:
    n_races, n_karts = f.shape[0], f.shape[1]
    n = straight.shape[0]
    target_at = OWN_FEATURES + OPPONENT_FEATURES * (n_karts - 1)
    ray_at = target_at + TARGET_FEATURES * HORIZON
    for b in range(n_races):
        for k in range(n_karts):
            o = out[b, k]
            o[0] = f[b, k, st.F_SPEED] / speed_unit
            o[1] = accelerating[b, k]
            o[2] = float(i[b, k, st.I_LANE_NOW])
            o[3] = float(i[b, k, st.I_STEP_LANE_COUNT]) / float(limit)
            o[4] = 1.0 - float(i[b, k, st.I_FINISHED])
            c_now = i[b, k, st.I_CP_PASSED] % n
            o[5] = float(c_now) / float(n)
            o[6] = straight[c_now]
            o[7] = f[b, k, st.F_WEAR]
            o[8] = time_fraction[b]
            x, y, heading = f[b, k, st.F_X], f[b, k, st.F_Y], f[b, k, st.F_HEADING]
            c, s = np.cos(heading), np.sin(heading)
            for shift in range(1, n_karts):
                j = (k + shift) % n_karts  # the others, in a fixed order per ego
                q = OWN_FEATURES + OPPONENT_FEATURES * (shift - 1)
                c_j = i[b, j, st.I_CP_PASSED] % n
                dx, dy = f[b, j, st.F_X] - x, f[b, j, st.F_Y] - y
                o[q] = f[b, j, st.F_SPEED] / speed_unit
                o[q + 1] = accelerating[b, j]
                o[q + 2] = float(i[b, j, st.I_LANE_NOW])
                o[q + 3] = float(i[b, j, st.I_STEP_LANE_COUNT]) / float(limit)
                o[q + 4] = 1.0 - float(i[b, j, st.I_FINISHED])
                o[q + 5] = straight[c_j]
                o[q + 6] = f[b, j, st.F_WEAR]
                o[q + 7] = float(c_j) / float(n)
                o[q + 8] = np.hypot(dx, dy)
                o[q + 9] = c * dx + s * dy
                o[q + 10] = -s * dx + c * dy
                o[q + 11] = (np.mod(f[b, j, st.F_HEADING] - heading + np.pi, 2 * np.pi) - np.pi) / np.pi
            passed = i[b, k, st.I_CP_PASSED]
            for h in range(HORIZON):
                c_t = (passed + 1 + h) % n
                q = target_at + TARGET_FEATURES * h
                lane = plan_lane[b, k, c_t]
                dx, dy = points[c_t, lane, 0] - x, points[c_t, lane, 1] - y
                o[q] = c * dx + s * dy
                o[q + 1] = -s * dx + c * dy
                o[q + 2] = np.hypot(dx, dy)
                o[q + 3] = plan_speed[b, k, c_t] / speed_unit
                o[q + 4] = straight[(c_t - 1) % n]
            for r in range(ray_dist.shape[2]):
                o[ray_at + r] = ray_dist[b, k, r] / max_range
