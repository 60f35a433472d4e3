"""The compiled step of the batched world: the phase order of one step for B races x K karts.

Each race is advanced by :func:`step_race` using only its own rows of the state arrays, so a race gives
bit-identical results whether it is stepped alone or inside a batch of any size.

Order within a step: kart dynamics (:mod:`sim_core.kart`) -> wall and kart-kart contacts
(:mod:`sim_core.contacts`) -> referee per kart: progress, checkpoints, lanes, lane-change rule, plan-following
metrics, finish (:mod:`sim_core.referee`) -> collisions at fault, contacts and safety buffers -> race clock ->
sensors (:mod:`sim_core.sensors`). A kart that has finished leaves the track: it is no longer moved, touched
or seen.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sim_core.contacts import resolve_contacts
from sim_core.kart import kart_step, tyre_wear
from sim_core.kernel_arrays import NO_REFCOUNT, PHASE, RayTables, StepScratch, TrackArrays, WorldArrays, scratch_views
from sim_core.referee import advance_clock, count_passes, judge_contacts, referee_kart
from sim_core.sensors import cast_rays
from sim_core.state import (
    F_ACC_YAW,
    F_D,
    F_HEADING,
    F_S,
    F_SLIP,
    F_SPEED,
    F_STEER,
    F_THROTTLE,
    F_WEAR,
    F_X,
    F_Y,
    F_YAW_RATE,
    I_CENTRE_IDX,
    I_EVENTS,
    I_FINISHED,
    PASS_CHECK_STEPS,
    R_DONE,
    R_STEP,
    RP_DT,
)


@njit(**PHASE)
def drive_karts(b: int, w: WorldArrays, actions: np.ndarray, kp: np.ndarray, dt: float, scratch: StepScratch) -> None:
    """The dynamics of every unfinished kart of race ``b`` under its action (contacts come after); ``kp`` holds
    every kart's own parameters (B, K, P)."""
    F, I = w.F, w.I
    for k in range(F.shape[1]):
        I[b, k, I_EVENTS] = 0
        scratch.prev_s[k] = F[b, k, F_S]
        scratch.prev_d[k] = F[b, k, F_D]
        if I[b, k, I_FINISHED]:
            continue
        steer, throttle = actions[b, k, 0], actions[b, k, 1]
        x, y, h, v, slip, yaw_rate, acc = kart_step(
            kp[b, k],
            F[b, k, F_X],
            F[b, k, F_Y],
            F[b, k, F_HEADING],
            F[b, k, F_SPEED],
            F[b, k, F_SLIP],
            F[b, k, F_ACC_YAW],
            steer,
            throttle,
            dt,
        )
        F[b, k, F_X], F[b, k, F_Y], F[b, k, F_HEADING], F[b, k, F_SPEED] = x, y, h, v
        F[b, k, F_SLIP] = slip
        scratch.heading_before[k], scratch.speed_before[k] = h, v
        F[b, k, F_YAW_RATE], F[b, k, F_ACC_YAW] = yaw_rate, acc
        F[b, k, F_WEAR] = tyre_wear(kp[b, k], acc)
        F[b, k, F_STEER] = min(max(steer, -1.0), 1.0) if steer == steer else 0.0
        F[b, k, F_THROTTLE] = min(max(throttle, -1.0), 1.0) if throttle == throttle else 0.0


@njit(**NO_REFCOUNT)
def step_race(
    b: int,
    w: WorldArrays,
    actions: np.ndarray,
    tr: TrackArrays,
    kp: np.ndarray,
    rp: np.ndarray,
    rays: RayTables,
    sensors_on: bool,
    scratch: StepScratch,
) -> None:
    """Advance race ``b`` by one step (no-op once the race is done)."""
    if w.R[b, R_DONE]:
        return
    K = w.F.shape[1]
    step = w.R[b, R_STEP]
    drive_karts(b, w, actions, kp, rp[RP_DT], scratch)
    resolve_contacts(b, w, tr, kp[b], rp, scratch)
    for k in range(K):
        if not w.I[b, k, I_FINISHED]:
            referee_kart(b, k, w, tr, rp, step, scratch)
    judge_contacts(b, w, tr, kp[b, 0], rp, step, scratch)  # headings are final from here on
    if step % PASS_CHECK_STEPS == 0:  # a pass takes 2 s to count: 10 Hz is plenty
        count_passes(b, w, tr, step, scratch)
    advance_clock(b, w, rp)
    if sensors_on:
        for k in range(K):  # every kart was located this step (a finished one has not moved since)
            scratch.centre[k, 0] = w.I[b, k, I_CENTRE_IDX]
            scratch.centre[k, 1] = w.F[b, k, F_D]
        cast_rays(b, w, tr, kp[b, 0], rp, rays, scratch)  # bodies: the same size for every kart


@njit(**NO_REFCOUNT)  # views and bundles only: nothing to count
def step_batch(
    F: np.ndarray,
    I: np.ndarray,
    R: np.ndarray,
    pair_flags: np.ndarray,
    target_lane: np.ndarray,
    target_speed: np.ndarray,
    ray_dist: np.ndarray,
    ray_hit: np.ndarray,
    pass_start: np.ndarray,
    finish_at: np.ndarray,
    actions: np.ndarray,
    tr: TrackArrays,
    kp: np.ndarray,
    rp: np.ndarray,
    rays: np.ndarray,
    sensors_on: bool,
    n_steps: int,
    scratch_floats: np.ndarray,
    scratch_bools: np.ndarray,
) -> None:
    """Advance every race of the batch by ``n_steps`` steps with the same actions held.

    The world's arrays come one by one (numba types a bundle passed in from Python several times slower than
    its arrays), ``rays`` is (3, rays): the :func:`sim_core.sensors.prepare_rays` tables, and the scratch
    buffers are the world's (see :func:`sim_core.kernel_arrays.scratch_views`).
    """
    w = WorldArrays(F, I, R, pair_flags, target_lane, target_speed, ray_dist, ray_hit, pass_start, finish_at)
    tables = RayTables(rays[0], rays[1], rays[2])
    scratch = scratch_views(scratch_floats, scratch_bools, F.shape[1], rays.shape[1])
    for _ in range(n_steps):
        for b in range(F.shape[0]):
            step_race(b, w, actions, tr, kp, rp, tables, sensors_on, scratch)
