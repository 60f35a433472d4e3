"""The referee of the compiled step: progress and checkpoints, laps and the finish, lanes and the lane-change
rule (eqs. (10)-(11), as they happen and as the original sampled them), plan-following metrics (delta_r,
delta_v), wall hits, collisions at fault, contacts and the safety buffers (eqs. (8)-(9)), and the race clock.
The rules themselves are in :mod:`sim_core.rules`, shared with the planners' discrete game."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim_core.geometry import body_axes, locate, point_segment_distance, wrap_mod
from sim_core.kart import P_HALF_LENGTH, P_RADIUS
from sim_core.kernel_arrays import NO_REFCOUNT, PHASE, StepScratch, TrackArrays, WorldArrays
from sim_core.rules import lane_change_update, required_buffer
from sim_core.state import (
    EV_CHECKPOINT,
    EV_CONTACT,
    EV_FAULT_COLLISION,
    EV_FINISHED,
    EV_ILLEGAL_LANE_CHANGE,
    EV_WALL_HIT,
    F_CROSS_SPEED,
    F_CROSS_TIME,
    F_CROSS_WEAR,
    F_D,
    F_DR_SUM,
    F_DV_SUM,
    F_FINISH_TIME,
    F_HEADING,
    F_S,
    F_SLIP,
    F_SPEED,
    F_WEAR,
    F_X,
    F_Y,
    I_BUFFER_VIOLATIONS,
    I_CENTRE_IDX,
    I_CONTACTS,
    I_CP_PASSED,
    I_DR_COUNT,
    I_DV_COUNT,
    I_EVENTS,
    I_FAULTS,
    I_FINISHED,
    I_ILLEGAL,
    I_ILLEGAL_CHECKPOINT,
    I_ILLEGAL_STEP,
    I_LANE,
    I_LANE_COUNT,
    I_LANE_NOW,
    I_LAST_FAULT_STEP,
    I_LAST_WALL_STEP,
    I_PASSES,
    I_STEP_LANE_COUNT,
    I_WALL_CONTACT,
    I_WALL_HITS,
    LANE_COUNTING_CHECKPOINT,
    PAIR_BUFFER,
    PAIR_CONTACT,
    PAIR_CONTACT_BITS,
    PAIR_CONTACT_SHIFT,
    PAIR_I_AHEAD,
    PAIR_ORDER_KNOWN,
    PAIR_PASS_BITS,
    PAIR_PASS_I_SHIFT,
    PAIR_PASS_J_SHIFT,
    PASS_HOLD_STEPS,
    PASS_MARGIN,
    R_DONE,
    R_STEP,
    RP_ALONGSIDE,
    RP_BEHIND_OVERLAP,
    RP_BUFFER_BEHIND,
    RP_BUFFER_SIDE,
    RP_DT,
    RP_FAULT_COOLDOWN_STEPS,
    RP_LANE_COUNTING,
    RP_LANE_DEADZONE,
    RP_LANE_HYSTERESIS,
    RP_LANE_LIMIT,
    RP_LAPS,
    RP_LATERAL_FAULT_SPEED,
    RP_TIME_LIMIT_STEPS,
)


@njit(**PHASE)
def referee_kart(
    b: int, k: int, w: WorldArrays, tr: TrackArrays, rp: np.ndarray, step: int, scratch: StepScratch
) -> None:
    """Locate kart k of race b after its move, count wall hits, and judge every checkpoint it crossed and its
    lane now."""
    F, I = w.F, w.I
    N = tr.checkpoint_s.shape[0]
    L = tr.length
    lane_limit = int(rp[RP_LANE_LIMIT])
    by_checkpoint = int(rp[RP_LANE_COUNTING]) == LANE_COUNTING_CHECKPOINT
    located = scratch.located
    prev_s = scratch.prev_s
    prev_d = scratch.prev_d
    passed_before = I[b, k, I_CP_PASSED]
    x, y = F[b, k, F_X], F[b, k, F_Y]
    if x == located[k, 0] and y == located[k, 1] and I[b, k, I_CENTRE_IDX] == located[k, 4]:
        # not moved since the wall check located it (locate from its own result returns the same)
        idx, s, d = I[b, k, I_CENTRE_IDX], located[k, 2], located[k, 3]
    else:
        idx, s, d = locate(tr, x, y, I[b, k, I_CENTRE_IDX])
    I[b, k, I_CENTRE_IDX] = idx
    F[b, k, F_S] = s
    F[b, k, F_D] = d
    if scratch.wall_touch[k]:
        # contact within the merge window of the last one is the same hit (a kart scraping along)
        if step - I[b, k, I_LAST_WALL_STEP] > int(rp[RP_FAULT_COOLDOWN_STEPS]):
            I[b, k, I_WALL_HITS] += 1
            I[b, k, I_EVENTS] |= EV_WALL_HIT
        I[b, k, I_LAST_WALL_STEP] = step
    I[b, k, I_WALL_CONTACT] = 1 if scratch.wall_touch[k] else 0
    ds = wrap_mod(s - prev_s[k] + 0.5 * L, L) - 0.5 * L
    while ds > 0.0 and not I[b, k, I_FINISHED]:
        c = (I[b, k, I_CP_PASSED] + 1) % N
        ahead = wrap_mod(tr.checkpoint_s[c] - prev_s[k], L)
        if ahead > ds:
            break
        frac = ahead / ds
        _cross_checkpoint(b, k, c, frac, prev_d[k] + frac * (d - prev_d[k]), w, tr, rp, step, by_checkpoint)
    finish_at = w.finish_at[b, k]
    if finish_at == finish_at and not I[b, k, I_FINISHED]:
        _finish_at_distance(b, k, finish_at, race_progress(tr, passed_before, prev_s[k]), w, tr, rp, step)
    # eqs. (10)-(11) as they happen: the lane the kart is in now (with hysteresis), every step
    lane_before = I[b, k, I_LANE_NOW]
    lane_now = lane_with_hysteresis(tr.sample_lane_offsets, idx, d, lane_before, rp[RP_LANE_HYSTERESIS])
    passed = I[b, k, I_CP_PASSED]
    if lane_now == lane_before and passed == passed_before:
        return  # (the common step: no lane change, no new section; the rule would change nothing)
    count, illegal = lane_change_update(
        I[b, k, I_STEP_LANE_COUNT],
        lane_before,
        lane_now,
        tr.straight[passed_before % N],
        tr.straight[passed % N],
        lane_limit,
    )
    I[b, k, I_STEP_LANE_COUNT] = count
    I[b, k, I_LANE_NOW] = lane_now
    if illegal:
        I[b, k, I_ILLEGAL_STEP] += 1
        if not by_checkpoint:
            I[b, k, I_ILLEGAL] += 1
            I[b, k, I_EVENTS] |= EV_ILLEGAL_LANE_CHANGE


@njit(**PHASE)
def _cross_checkpoint(
    b: int,
    k: int,
    c: int,
    frac: float,
    d_cross: float,
    w: WorldArrays,
    tr: TrackArrays,
    rp: np.ndarray,
    step: int,
    by_checkpoint: bool,
) -> None:
    """Kart k crossed checkpoint c at fraction ``frac`` of this step, ``d_cross`` m off the centre line: time,
    speed and wear of the crossing, the lane there (the original's lane-change rule), delta_r / delta_v
    against the planned targets, and the finish."""
    F, I = w.F, w.I
    target_lane, target_speed = w.target_lane, w.target_speed
    N = tr.checkpoint_s.shape[0]
    dt = rp[RP_DT]
    deadzone = rp[RP_LANE_DEADZONE]
    lane_limit = int(rp[RP_LANE_LIMIT])
    I[b, k, I_CP_PASSED] += 1
    I[b, k, I_EVENTS] |= EV_CHECKPOINT
    F[b, k, F_CROSS_TIME] = (step + frac) * dt
    F[b, k, F_CROSS_SPEED] = F[b, k, F_SPEED]
    F[b, k, F_CROSS_WEAR] = F[b, k, F_WEAR]
    lane = 1
    best = abs(tr.lane_offsets[c, 0] - d_cross)
    for q in range(1, tr.lane_offsets.shape[1]):
        gap = abs(tr.lane_offsets[c, q] - d_cross)
        if gap < best:
            best, lane = gap, q + 1
    count, illegal = lane_change_update(
        I[b, k, I_LANE_COUNT], I[b, k, I_LANE], lane, tr.straight[(c - 1) % N], tr.straight[c], lane_limit
    )
    I[b, k, I_LANE_COUNT] = count
    I[b, k, I_LANE] = lane
    if illegal:
        I[b, k, I_ILLEGAL_CHECKPOINT] += 1
        if by_checkpoint:
            I[b, k, I_ILLEGAL] += 1
            I[b, k, I_EVENTS] |= EV_ILLEGAL_LANE_CHANGE
    wanted = target_lane[b, k, c]
    if wanted > 0:
        miss = abs(d_cross - tr.lane_offsets[c, wanted - 1])
        F[b, k, F_DR_SUM] += max(miss - deadzone, 0.0)
        I[b, k, I_DR_COUNT] += 1
        target_lane[b, k, c] = 0
    wanted_speed = target_speed[b, k, c]
    if wanted_speed == wanted_speed:
        F[b, k, F_DV_SUM] += abs(F[b, k, F_SPEED] - wanted_speed)
        I[b, k, I_DV_COUNT] += 1
        target_speed[b, k, c] = np.nan
    if I[b, k, I_CP_PASSED] >= int(rp[RP_LAPS]) * N and w.finish_at[b, k] != w.finish_at[b, k]:
        I[b, k, I_FINISHED] = 1
        F[b, k, F_FINISH_TIME] = (step + frac) * dt
        I[b, k, I_EVENTS] |= EV_FINISHED


@njit(**PHASE)
def _finish_at_distance(
    b: int, k: int, finish_at: float, before: float, w: WorldArrays, tr: TrackArrays, rp: np.ndarray, step: int
) -> None:
    """The finish of a kart that races a distance (``finish_at``: every kart the same distance from its grid
    slot): it finishes when its progress reaches ``finish_at``, at the time interpolated within the step."""
    F, I = w.F, w.I
    now = race_progress(tr, I[b, k, I_CP_PASSED], F[b, k, F_S])
    if now < finish_at:
        return
    frac = min(max((finish_at - before) / (now - before), 0.0), 1.0) if now > before else 1.0
    I[b, k, I_FINISHED] = 1
    F[b, k, F_FINISH_TIME] = (step + frac) * rp[RP_DT]
    I[b, k, I_EVENTS] |= EV_FINISHED


@njit(cache=True, inline="always")
def race_progress(tr: TrackArrays, passed: int, s: float) -> float:
    """[m] a kart's progress toward the finish: the laps and checkpoints it has passed (``passed``) and its way
    past the last one to ``s`` (negative when it was driven back over it)."""
    N = tr.checkpoint_s.shape[0]
    L = tr.length
    last = passed % N
    since = wrap_mod(s - tr.checkpoint_s[last], L)
    if since > 0.5 * L:  # just behind its last checkpoint (driven back over it)
        since -= L
    return (passed // N) * L + tr.checkpoint_s[last] + since


@njit(**PHASE)
def judge_contacts(
    b: int, w: WorldArrays, tr: TrackArrays, kp: np.ndarray, rp: np.ndarray, step: int, scratch: StepScratch
) -> None:
    """Collisions at fault (new contacts), contact counts and the s0/s1 safety buffers of race b (headings are
    final by now; ``scratch.bodies`` is filled here for the sensors too)."""
    F, I = w.F, w.I
    pair_flags = w.pair_flags
    K = F.shape[1]
    L = tr.length
    hl = kp[P_HALF_LENGTH]
    r = kp[P_RADIUS]
    body = scratch.bodies
    body_axes(b, F, hl, body)
    fault_touch = scratch.fault_touch
    fault_touch[:] = False
    first_touch, front, contact = scratch.first_touch, scratch.front, scratch.contact
    speed_before = scratch.speed_before
    cooldown = int(rp[RP_FAULT_COOLDOWN_STEPS])
    for i in range(K):
        for j in range(i + 1, K):
            if first_touch[i, j]:
                charge_contact(tr, F, I, b, i, j, front, speed_before, rp, fault_touch)
    for k in range(K):
        if fault_touch[k]:
            if step - I[b, k, I_LAST_FAULT_STEP] > cooldown:
                I[b, k, I_FAULTS] += 1
                I[b, k, I_EVENTS] |= EV_FAULT_COLLISION
            I[b, k, I_LAST_FAULT_STEP] = step
    for i in range(K):
        for j in range(K):
            if i == j:
                continue
            flags = pair_flags[b, i, j]
            if i < j:
                touching = contact[i, j]
                if touching and not (flags & PAIR_CONTACT):
                    I[b, i, I_CONTACTS] += 1
                    I[b, j, I_CONTACTS] += 1
                    I[b, i, I_EVENTS] |= EV_CONTACT
                    I[b, j, I_EVENTS] |= EV_CONTACT
                    flags = add_pair_count(flags, PAIR_CONTACT_SHIFT, PAIR_CONTACT_BITS)
                flags = (flags | PAIR_CONTACT) if touching else (flags & ~PAIR_CONTACT)
            violating = False
            if not I[b, i, I_FINISHED] and not I[b, j, I_FINISHED]:
                nose_x = F[b, i, F_X] + (hl + r) * body[i, 0]
                nose_y = F[b, i, F_Y] + (hl + r) * body[i, 1]
                cj, sj = body[j, 0], body[j, 1]
                gap = (
                    point_segment_distance(
                        nose_x,
                        nose_y,
                        F[b, j, F_X] - hl * cj,
                        F[b, j, F_Y] - hl * sj,
                        F[b, j, F_X] + hl * cj,
                        F[b, j, F_Y] + hl * sj,
                    )
                    - r
                )
                if gap < max(rp[RP_BUFFER_BEHIND], rp[RP_BUFFER_SIDE]):
                    ahead = wrap_mod(F[b, j, F_S] - F[b, i, F_S] + 0.5 * L, L) - 0.5 * L
                    behind = ahead > 0.0 and abs(F[b, j, F_D] - F[b, i, F_D]) < rp[RP_BEHIND_OVERLAP]
                    violating = gap < required_buffer(behind, rp[RP_BUFFER_SIDE], rp[RP_BUFFER_BEHIND])
            if violating and not (flags & PAIR_BUFFER):
                I[b, i, I_BUFFER_VIOLATIONS] += 1
            flags = (flags | PAIR_BUFFER) if violating else (flags & ~PAIR_BUFFER)
            pair_flags[b, i, j] = flags


@njit(cache=True, inline="always")
def add_pair_count(flags: int, shift: int, bits: int) -> int:
    """``flags`` with the count in its ``bits`` bits from ``shift`` one higher (unless it is full)."""
    if (flags >> shift) & ((1 << bits) - 1) < (1 << bits) - 1:
        flags += 1 << shift
    return flags


def pair_count(flags: np.ndarray, shift: int, bits: int) -> np.ndarray:
    """The counts in ``bits`` bits from ``shift`` of pair flag words ``flags`` (any shape)."""
    return (flags >> shift) & ((1 << bits) - 1)


@njit(**PHASE)
def count_passes(b: int, w: WorldArrays, tr: TrackArrays, step: int, scratch: StepScratch) -> None:
    """Overtakes: when kart i gets ahead of kart j (by more than ``PASS_MARGIN`` of progress toward the finish)
    after running behind it, the pass counts for i once it has held the place for ``PASS_HOLD_STEPS`` or
    finished ahead; losing the place back first cancels it. The order on the grid is not a pass."""
    F, I = w.F, w.I
    K = F.shape[1]
    progress = scratch.progress
    for k in range(K):
        progress[k] = race_progress(tr, I[b, k, I_CP_PASSED], F[b, k, F_S])
    flags_all = w.pair_flags
    for i in range(K):
        for j in range(i + 1, K):
            flags = flags_all[b, i, j]
            gap = progress[i] - progress[j]
            if gap > PASS_MARGIN:
                ahead, behind = i, j
            elif gap < -PASS_MARGIN:
                ahead, behind = j, i
            else:
                ahead = -1
                behind = -1
            if ahead >= 0:
                i_ahead = ahead == i
                was_known = (flags & PAIR_ORDER_KNOWN) != 0
                was_i_ahead = (flags & PAIR_I_AHEAD) != 0
                if was_known and i_ahead != was_i_ahead:
                    # the order changed: a pass under way for the new leader; the old leader's one is void
                    w.pass_start[b, behind, ahead] = 0
                    w.pass_start[b, ahead, behind] = step + 1
                flags |= PAIR_ORDER_KNOWN
                flags = (flags | PAIR_I_AHEAD) if i_ahead else (flags & ~PAIR_I_AHEAD)
                flags_all[b, i, j] = flags
            for a, o in ((i, j), (j, i)):
                start = w.pass_start[b, a, o]
                if start > 0 and (step + 1 - start >= PASS_HOLD_STEPS or I[b, a, I_FINISHED]):
                    I[b, a, I_PASSES] += 1
                    w.pass_start[b, a, o] = 0
                    shift = PAIR_PASS_I_SHIFT if a < o else PAIR_PASS_J_SHIFT
                    flags_all[b, i, j] = add_pair_count(flags_all[b, i, j], shift, PAIR_PASS_BITS)


@njit(**PHASE)
def advance_clock(b: int, w: WorldArrays, rp: np.ndarray) -> None:
    """One step more on race b's clock; the race is done once every kart finished or the time ran out."""
    I, R = w.I, w.R
    K = I.shape[1]
    step = R[b, R_STEP] + 1
    R[b, R_STEP] = step
    all_finished = True
    for k in range(K):
        if not I[b, k, I_FINISHED]:
            all_finished = False
    if all_finished or step >= rp[RP_TIME_LIMIT_STEPS]:
        R[b, R_DONE] = 1


@njit(cache=True, inline="always")
def lane_with_hysteresis(offsets: np.ndarray, row: int, d: float, current: int, hysteresis: float) -> int:
    """The lane (1-based) a kart at lateral offset ``d`` is in, given the lane ``current`` it was in (lane
    offsets in ``offsets[row]``): the nearest lane, but a kart leaves its lane only once it is ``hysteresis``
    past the midpoint toward the other."""
    nearest = 0
    best = abs(offsets[row, 0] - d)
    for q in range(1, offsets.shape[1]):
        gap = abs(offsets[row, q] - d)
        if gap < best:
            best, nearest = gap, q
    nearest += 1
    if nearest == current or current < 1:
        return nearest
    if abs(offsets[row, current - 1] - d) - best > 2.0 * hysteresis:
        return nearest
    return current


@njit(**NO_REFCOUNT)
def charge_contact(
    tr: TrackArrays,
    F: np.ndarray,
    I: np.ndarray,
    b: int,
    i: int,
    j: int,
    front: np.ndarray,
    speed_before: np.ndarray,
    rp: np.ndarray,
    fault_touch: np.ndarray,
) -> None:
    """Who is at fault for a new contact of karts i and j (paper section 3: the follower is responsible).

    Apart along the track by ``RP_ALONGSIDE`` or more: the follower, if its front touched the other (the
    original's frontal cone). Alongside (closer than that): each kart that was moving laterally toward the
    other faster than ``RP_LATERAL_FAULT_SPEED``; both when both did (each broke the rule by itself; calling
    it a racing incident would let a kart swerve into one that is correcting its own line unpunished); neither
    when neither did (side-by-side rubbing).
    """
    L = tr.length
    ahead = wrap_mod(F[b, j, F_S] - F[b, i, F_S] + 0.5 * L, L) - 0.5 * L  # > 0: j leads
    if abs(ahead) >= rp[RP_ALONGSIDE]:
        if ahead > 0.0:
            fault_touch[i] |= front[i, j]
        else:
            fault_touch[j] |= front[j, i]
        return
    toward_j = 1.0 if F[b, j, F_D] > F[b, i, F_D] else -1.0
    threshold = rp[RP_LATERAL_FAULT_SPEED]
    if lateral_speed(tr, F, I, b, i, speed_before[i]) * toward_j > threshold:
        fault_touch[i] = True
    if -lateral_speed(tr, F, I, b, j, speed_before[j]) * toward_j > threshold:
        fault_touch[j] = True


@njit(cache=True, inline="always")
def lateral_speed(tr: TrackArrays, F: np.ndarray, I: np.ndarray, b: int, k: int, speed: float) -> float:
    """Kart k's velocity [m/s] across the track (left-positive), at ``speed`` along its course."""
    idx = I[b, k, I_CENTRE_IDX]
    tx, ty = tr.seg_tangent[idx, 0], tr.seg_tangent[idx, 1]
    course = F[b, k, F_HEADING] + F[b, k, F_SLIP]
    return speed * (math.cos(course) * -ty + math.sin(course) * tx)
