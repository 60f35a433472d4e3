"""The compiled step of the batched world: physics, contacts, referee and sensors for B races x K karts.

Each race is advanced by :func:`step_race` using only its own rows of the state arrays, so a race gives
bit-identical results whether it is stepped alone or inside a batch of any size.

Order within a step: kart dynamics -> wall and kart-kart contact resolution (a few relaxation rounds)
-> referee (checkpoints, lanes, lane-change rule, plan-following metrics, finish) -> collision fault and
safety buffers -> race clock -> sensors. A kart that has finished leaves the track: it is no longer moved,
touched or seen.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from sim_core.geometry import (
    TrackArrays,
    centre_normal,
    locate,
    point_segment_distance,
    ray_bin_scaled,
    ray_capsule,
    ray_cell,
    ray_fan_walls,
    ray_first_wall,
    segment_closest,
)
from sim_core.kart import (
    P_HALF_LENGTH,
    P_RADIUS,
    P_REVERSE_SPEED,
    P_TOP_SPEED,
    P_WALL_FRICTION,
    P_WALL_YAW_RATE,
    kart_step,
    max_slip,
    tyre_wear,
)
from sim_core.rules import front_touches, lane_change_update, required_buffer
from sim_core.state import (
    EV_CHECKPOINT,
    EV_CONTACT,
    EV_FAULT_COLLISION,
    EV_FINISHED,
    EV_ILLEGAL_LANE_CHANGE,
    EV_WALL_HIT,
    F_ACC_YAW,
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
    F_STEER,
    F_THROTTLE,
    F_WEAR,
    F_X,
    F_Y,
    F_YAW_RATE,
    HIT_KART,
    HIT_NONE,
    HIT_WALL,
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
    I_STEP_LANE_COUNT,
    I_WALL_CONTACT,
    I_WALL_HITS,
    LANE_COUNTING_CHECKPOINT,
    R_DONE,
    R_STEP,
    RP_ALONGSIDE,
    RP_BEHIND_OVERLAP,
    RP_BUFFER_BEHIND,
    RP_BUFFER_SIDE,
    RP_CONE_COS,
    RP_CONTACT_MARGIN,
    RP_DT,
    RP_FAULT_COOLDOWN_STEPS,
    RP_LANE_COUNTING,
    RP_LANE_DEADZONE,
    RP_LANE_HYSTERESIS,
    RP_LANE_LIMIT,
    RP_LAPS,
    RP_LATERAL_FAULT_SPEED,
    RP_RAY_ORIGIN,
    RP_RAY_RANGE,
    RP_TIME_LIMIT_STEPS,
)

# The per-race kernels run without numba's reference counting: they allocate nothing, and counting the
# references of every array passed to or taken from a namedtuple (atomic updates) was half of a step's time.
_NO_REFCOUNT: dict[str, Any] = {"cache": True, "_nrt": False}

ORIGIN_TRACK_MARGIN = 0.1  # [m] sensor origins this far inside the walls' nominal offsets use the bin lists
PAIR_BUFFER = 1  # bit in the pair flags: the nose-side kart is inside its buffer
PAIR_CONTACT = 2  # bit in the pair flags: the two bodies touch
CONTACT_ROUNDS = 4  # relaxation rounds of wall and kart-kart contact per step


@njit(**_NO_REFCOUNT)
def _resolve_walls(
    tr: TrackArrays,
    kp: np.ndarray,
    F: np.ndarray,
    I: np.ndarray,
    b: int,
    k: int,
    dt: float,
    located: np.ndarray,
    heading_before: float,
) -> bool:
    """Push kart k out of the walls; a kart driving into a wall slides along it and loses speed.

    The slide is the kart's direction of travel at once (its slip angle takes the difference, up to the
    kinematic limit); the body turns toward the wall's tangent at most ``wall_yaw_rate`` from
    ``heading_before`` (its heading before this step's contacts), so a wall never snaps the heading.
    ``located[k]`` keeps [x, y, s, d, sample index] of the kart's last located position (the referee reuses
    it when the kart has not moved since).
    """
    hl = kp[P_HALF_LENGTH]
    r = kp[P_RADIUS]
    touched = False
    for _ in range(2):
        x, y, h = F[b, k, F_X], F[b, k, F_Y], F[b, k, F_HEADING]
        idx, s, d = locate(tr, x, y, I[b, k, I_CENTRE_IDX])
        I[b, k, I_CENTRE_IDX] = idx
        located[k, 0], located[k, 1], located[k, 2], located[k, 3], located[k, 4] = x, y, s, d, idx
        # the lateral offset is 1-Lipschitz, so a body within hl of the centre cannot reach a wall that is
        # farther than |d| + hl + r anywhere nearby
        if d + hl + r < tr.near_width_left[idx] and hl + r - d < tr.near_width_right[idx]:
            break
        ch, sh = math.cos(h), math.sin(h)
        worst = 0.0
        push_x, push_y = 0.0, 0.0
        for frac in (1.0, 0.0, -1.0):  # front end, centre, rear end of the body axis
            j, _sj, dj = locate(tr, x + frac * hl * ch, y + frac * hl * sh, idx)
            nx, ny = centre_normal(tr, j)
            over_left = dj + r - tr.width_left[j]
            over_right = -tr.width_right[j] - (dj - r)
            if over_left > worst:
                worst, push_x, push_y = over_left, -nx, -ny
            if over_right > worst:
                worst, push_x, push_y = over_right, nx, ny
        if worst <= 0.0:
            break
        touched = True
        F[b, k, F_X] = x + push_x * worst
        F[b, k, F_Y] = y + push_y * worst
        speed = F[b, k, F_SPEED]
        course = h + F[b, k, F_SLIP]
        ux, uy = speed * math.cos(course), speed * math.sin(course)
        into = ux * push_x + uy * push_y
        if into < 0.0:
            tx, ty = -push_y, push_x  # a wall tangent
            along = ux * tx + uy * ty
            if abs(along) < 1e-9:
                # head-on: slide toward the track's forward direction
                nx, ny = centre_normal(tr, idx)
                along = 1e-9 if (tx * ny - ty * nx) > 0.0 else -1e-9
            sign = 1.0 if along > 0.0 else -1.0
            # Coulomb friction: the harder the kart drives into the wall, the more sliding speed it loses
            slide = max(abs(along) + kp[P_WALL_FRICTION] * into, 0.0)
            slide_dir = math.atan2(sign * ty, sign * tx)
            # the body's course (heading + slip) points along the slide, backwards when reversing
            course_target = slide_dir if speed >= 0.0 else _wrap_angle(slide_dir + math.pi)
            turn_limit = kp[P_WALL_YAW_RATE] * dt
            turned = _wrap_angle(course_target - heading_before)
            turned = min(max(turned, -turn_limit), turn_limit)
            new_heading = _wrap_angle(heading_before + turned)
            slip_limit = max_slip(kp)
            F[b, k, F_HEADING] = new_heading
            F[b, k, F_SLIP] = min(max(_wrap_angle(course_target - new_heading), -slip_limit), slip_limit)
            F[b, k, F_SPEED] = slide if speed >= 0.0 else -slide
    return touched


@njit(**_NO_REFCOUNT)
def _resolve_pair(
    kp: np.ndarray, F: np.ndarray, b: int, i: int, j: int, margin: float, cone_cos: float
) -> tuple[bool, bool, bool]:
    """Separate karts i and j if their capsules overlap (symmetric push, inelastic along the normal).

    Returns (in contact, i's front touches j, j's front touches i).
    """
    hl = kp[P_HALF_LENGTH]
    r = kp[P_RADIUS]
    xi, yi, hi = F[b, i, F_X], F[b, i, F_Y], F[b, i, F_HEADING]
    xj, yj, hj = F[b, j, F_X], F[b, j, F_Y], F[b, j, F_HEADING]
    if (xi - xj) ** 2 + (yi - yj) ** 2 > (2.0 * (hl + r) + margin) ** 2:
        return False, False, False
    ci, si_ = math.cos(hi), math.sin(hi)
    cj, sj_ = math.cos(hj), math.sin(hj)
    dist, ti, tj = segment_closest(
        xi - hl * ci,
        yi - hl * si_,
        xi + hl * ci,
        yi + hl * si_,
        xj - hl * cj,
        yj - hl * sj_,
        xj + hl * cj,
        yj + hl * sj_,
    )
    if dist >= 2.0 * r + margin:
        return False, False, False
    # normal from j's closest point to i's closest point
    pix, piy = xi + (2.0 * ti - 1.0) * hl * ci, yi + (2.0 * ti - 1.0) * hl * si_
    pjx, pjy = xj + (2.0 * tj - 1.0) * hl * cj, yj + (2.0 * tj - 1.0) * hl * sj_
    nx, ny = pix - pjx, piy - pjy
    norm = math.sqrt(nx * nx + ny * ny)
    if norm < 1e-9:
        nx, ny = xi - xj, yi - yj
        norm = math.sqrt(nx * nx + ny * ny)
        if norm < 1e-9:
            nx, ny, norm = -si_, ci, 1.0
    nx, ny = nx / norm, ny / norm
    i_faults = front_touches(ti, -(nx * ci + ny * si_), cone_cos)
    j_faults = front_touches(tj, nx * cj + ny * sj_, cone_cos)
    penetration = 2.0 * r - dist
    if penetration > 0.0:
        half = 0.5 * penetration
        F[b, i, F_X] += nx * half
        F[b, i, F_Y] += ny * half
        F[b, j, F_X] -= nx * half
        F[b, j, F_Y] -= ny * half
        vi, vj = F[b, i, F_SPEED], F[b, j, F_SPEED]
        closing = (vi * ci - vj * cj) * nx + (vi * si_ - vj * sj_) * ny
        if closing < 0.0:
            # equal masses, perfectly inelastic along the normal; the no-slip kart keeps its heading component
            uix, uiy = vi * ci - 0.5 * closing * nx, vi * si_ - 0.5 * closing * ny
            ujx, ujy = vj * cj + 0.5 * closing * nx, vj * sj_ + 0.5 * closing * ny
            # a push never takes a kart past its own speed limits
            top, reverse = kp[P_TOP_SPEED], -kp[P_REVERSE_SPEED]
            F[b, i, F_SPEED] = min(max(uix * ci + uiy * si_, reverse), top)
            F[b, j, F_SPEED] = min(max(ujx * cj + ujy * sj_, reverse), top)
    return True, i_faults, j_faults


@njit(**_NO_REFCOUNT)
def step_race(
    b: int,
    F: np.ndarray,
    I: np.ndarray,
    R: np.ndarray,
    pair_flags: np.ndarray,
    target_lane: np.ndarray,
    target_speed: np.ndarray,
    ray_dist: np.ndarray,
    ray_hit: np.ndarray,
    actions: np.ndarray,
    tr: TrackArrays,
    kp: np.ndarray,
    rp: np.ndarray,
    ray_bins: np.ndarray,
    ray_cos: np.ndarray,
    ray_sin: np.ndarray,
    sensors_on: bool,
    scratch_f: np.ndarray,
    scratch_b: np.ndarray,
    scratch_pairs: np.ndarray,
    scratch_bodies: np.ndarray,
    scratch_located: np.ndarray,
    scratch_fan: np.ndarray,
    scratch_centre: np.ndarray,
    scratch_touch: np.ndarray,
) -> None:
    """Advance race ``b`` by one step (no-op once the race is done); ``scratch_*`` are work arrays."""
    if R[b, R_DONE]:
        return
    K = F.shape[1]
    N = tr.checkpoint_s.shape[0]
    L = tr.length
    dt = rp[RP_DT]
    step = R[b, R_STEP]
    hl = kp[P_HALF_LENGTH]
    r = kp[P_RADIUS]
    prev_s = scratch_f[0]
    prev_d = scratch_f[1]
    heading_before = scratch_f[2]  # after the dynamics, before contacts
    speed_before = scratch_f[3]
    located = scratch_located

    # ---- dynamics
    for k in range(K):
        I[b, k, I_EVENTS] = 0
        prev_s[k] = F[b, k, F_S]
        prev_d[k] = F[b, k, F_D]
        if I[b, k, I_FINISHED]:
            continue
        steer, throttle = actions[b, k, 0], actions[b, k, 1]
        x, y, h, v, slip, w, acc = kart_step(
            kp,
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
        heading_before[k], speed_before[k] = h, v
        F[b, k, F_YAW_RATE], F[b, k, F_ACC_YAW] = w, acc
        F[b, k, F_WEAR] = tyre_wear(kp, acc)
        F[b, k, F_STEER] = min(max(steer, -1.0), 1.0) if steer == steer else 0.0
        F[b, k, F_THROTTLE] = min(max(throttle, -1.0), 1.0) if throttle == throttle else 0.0

    # ---- contacts: walls and kart-kart, relaxed over a few rounds
    wall_touch = scratch_b[0]
    fault_touch = scratch_b[1]
    contact = scratch_pairs
    first_touch = scratch_touch[0]  # [i, j], i < j: touching in the first contact round
    front = scratch_touch[1]  # [i, j]: i's front touches j (first round)
    wall_touch[:] = False
    fault_touch[:] = False
    contact[:, :] = False
    first_touch[:, :] = False
    margin = rp[RP_CONTACT_MARGIN]
    cone = rp[RP_CONE_COS]
    any_pair = False
    for rnd in range(CONTACT_ROUNDS):
        for k in range(K):
            if not I[b, k, I_FINISHED] and _resolve_walls(tr, kp, F, I, b, k, dt, located, heading_before[k]):
                wall_touch[k] = True
        any_pair = False
        for i in range(K):
            if I[b, i, I_FINISHED]:
                continue
            for j in range(i + 1, K):
                if I[b, j, I_FINISHED]:
                    continue
                touching, i_fault, j_fault = _resolve_pair(kp, F, b, i, j, margin, cone)
                if touching:
                    any_pair = True
                    contact[i, j] = True
                    if rnd == 0:
                        first_touch[i, j] = True
                        front[i, j] = i_fault
                        front[j, i] = j_fault
        if not any_pair:
            break
    if any_pair:
        # kart-kart pushes of the last round may have moved a kart into a wall
        for k in range(K):
            if not I[b, k, I_FINISHED] and _resolve_walls(tr, kp, F, I, b, k, dt, located, heading_before[k]):
                wall_touch[k] = True

    # ---- referee: progress, checkpoints, lanes, lane-change rule, plan following, finish
    laps = int(rp[RP_LAPS])
    lane_limit = int(rp[RP_LANE_LIMIT])
    deadzone = rp[RP_LANE_DEADZONE]
    by_checkpoint = int(rp[RP_LANE_COUNTING]) == LANE_COUNTING_CHECKPOINT
    for k in range(K):
        if I[b, k, I_FINISHED]:
            continue
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
        if wall_touch[k]:
            # contact within the merge window of the last one is the same hit (a kart scraping along)
            if step - I[b, k, I_LAST_WALL_STEP] > int(rp[RP_FAULT_COOLDOWN_STEPS]):
                I[b, k, I_WALL_HITS] += 1
                I[b, k, I_EVENTS] |= EV_WALL_HIT
            I[b, k, I_LAST_WALL_STEP] = step
        I[b, k, I_WALL_CONTACT] = 1 if wall_touch[k] else 0
        ds = _wrap_mod(s - prev_s[k] + 0.5 * L, L) - 0.5 * L
        while ds > 0.0 and not I[b, k, I_FINISHED]:
            c = (I[b, k, I_CP_PASSED] + 1) % N
            ahead = _wrap_mod(tr.checkpoint_s[c] - prev_s[k], L)
            if ahead > ds:
                break
            frac = ahead / ds
            d_cross = prev_d[k] + frac * (d - prev_d[k])
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
            if I[b, k, I_CP_PASSED] >= laps * N:
                I[b, k, I_FINISHED] = 1
                F[b, k, F_FINISH_TIME] = (step + frac) * dt
                I[b, k, I_EVENTS] |= EV_FINISHED
        # eqs. (10)-(11) as they happen: the lane the kart is in now (with hysteresis), every step
        lane_now = _lane_with_hysteresis(tr.sample_lane_offsets[idx], d, I[b, k, I_LANE_NOW], rp[RP_LANE_HYSTERESIS])
        count, illegal = lane_change_update(
            I[b, k, I_STEP_LANE_COUNT],
            I[b, k, I_LANE_NOW],
            lane_now,
            tr.straight[passed_before % N],
            tr.straight[I[b, k, I_CP_PASSED] % N],
            lane_limit,
        )
        I[b, k, I_STEP_LANE_COUNT] = count
        I[b, k, I_LANE_NOW] = lane_now
        if illegal:
            I[b, k, I_ILLEGAL_STEP] += 1
            if not by_checkpoint:
                I[b, k, I_ILLEGAL] += 1
                I[b, k, I_EVENTS] |= EV_ILLEGAL_LANE_CHANGE

    # ---- collisions at fault, contacts and safety buffers (headings are final from here on)
    body = scratch_bodies
    _bodies(b, F, hl, body)
    cooldown = int(rp[RP_FAULT_COOLDOWN_STEPS])
    for i in range(K):
        for j in range(i + 1, K):
            if first_touch[i, j]:
                _charge_contact(tr, F, I, b, i, j, front, speed_before, rp, fault_touch)
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
                    ahead = _wrap_mod(F[b, j, F_S] - F[b, i, F_S] + 0.5 * L, L) - 0.5 * L
                    behind = ahead > 0.0 and abs(F[b, j, F_D] - F[b, i, F_D]) < rp[RP_BEHIND_OVERLAP]
                    violating = gap < required_buffer(behind, rp[RP_BUFFER_SIDE], rp[RP_BUFFER_BEHIND])
            if violating and not (flags & PAIR_BUFFER):
                I[b, i, I_BUFFER_VIOLATIONS] += 1
            flags = (flags | PAIR_BUFFER) if violating else (flags & ~PAIR_BUFFER)
            pair_flags[b, i, j] = flags

    # ---- race clock
    step += 1
    R[b, R_STEP] = step
    all_finished = True
    for k in range(K):
        if not I[b, k, I_FINISHED]:
            all_finished = False
    if all_finished or step >= rp[RP_TIME_LIMIT_STEPS]:
        R[b, R_DONE] = 1

    if sensors_on:
        centre = scratch_centre
        for k in range(K):  # every kart was located this step (a finished one has not moved since)
            centre[k, 0] = I[b, k, I_CENTRE_IDX]
            centre[k, 1] = F[b, k, F_D]
        cast_rays(b, F, I, ray_dist, ray_hit, tr, kp, rp, ray_bins, ray_cos, ray_sin, body, scratch_fan, centre)


@njit(cache=True, inline="always")
def _lane_with_hysteresis(offsets: np.ndarray, d: float, current: int, hysteresis: float) -> int:
    """The lane (1-based) a kart at lateral offset ``d`` is in, given the lane ``current`` it was in: the nearest
    lane, but a kart leaves its lane only once it is ``hysteresis`` past the midpoint toward the other."""
    nearest = 0
    best = abs(offsets[0] - d)
    for q in range(1, offsets.shape[0]):
        gap = abs(offsets[q] - d)
        if gap < best:
            best, nearest = gap, q
    nearest += 1
    if nearest == current or current < 1:
        return nearest
    if abs(offsets[current - 1] - d) - best > 2.0 * hysteresis:
        return nearest
    return current


@njit(**_NO_REFCOUNT)
def _charge_contact(
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
    ahead = _wrap_mod(F[b, j, F_S] - F[b, i, F_S] + 0.5 * L, L) - 0.5 * L  # > 0: j leads
    if abs(ahead) >= rp[RP_ALONGSIDE]:
        if ahead > 0.0:
            fault_touch[i] |= front[i, j]
        else:
            fault_touch[j] |= front[j, i]
        return
    toward_j = 1.0 if F[b, j, F_D] > F[b, i, F_D] else -1.0
    threshold = rp[RP_LATERAL_FAULT_SPEED]
    if _lateral_speed(tr, F, I, b, i, speed_before[i]) * toward_j > threshold:
        fault_touch[i] = True
    if -_lateral_speed(tr, F, I, b, j, speed_before[j]) * toward_j > threshold:
        fault_touch[j] = True


@njit(cache=True, inline="always")
def _lateral_speed(tr: TrackArrays, F: np.ndarray, I: np.ndarray, b: int, k: int, speed: float) -> float:
    """Kart k's velocity [m/s] across the track (left-positive), at ``speed`` along its course."""
    idx = I[b, k, I_CENTRE_IDX]
    tx, ty = tr.seg_tangent[idx, 0], tr.seg_tangent[idx, 1]
    course = F[b, k, F_HEADING] + F[b, k, F_SLIP]
    return speed * (math.cos(course) * -ty + math.sin(course) * tx)


@njit(cache=True, inline="always")
def _wrap_angle(a: float) -> float:
    """``a`` wrapped into [-pi, pi)."""
    w = a + math.pi
    if not 0.0 < w < 2.0 * math.pi:
        w %= 2.0 * math.pi
    return w - math.pi


@njit(cache=True, inline="always")
def _wrap_mod(x: float, m: float) -> float:
    """``x % m`` (m > 0), without the library call when x already lies in (0, m)."""
    if 0.0 < x < m:
        return x
    return x % m


@njit(cache=True, inline="always")
def _bodies(b: int, F: np.ndarray, hl: float, body: np.ndarray) -> None:
    """Every kart's heading cos and sin and body axis end points: body[k] = [cos, sin, rear x, rear y,
    front x, front y]."""
    for k in range(F.shape[1]):
        x, y = F[b, k, F_X], F[b, k, F_Y]
        h = F[b, k, F_HEADING]
        c, s = math.cos(h), math.sin(h)
        body[k, 0] = c
        body[k, 1] = s
        body[k, 2] = x - hl * c
        body[k, 3] = y - hl * s
        body[k, 4] = x + hl * c
        body[k, 5] = y + hl * s


@njit(**_NO_REFCOUNT)
def cast_rays(
    b: int,
    F: np.ndarray,
    I: np.ndarray,
    ray_dist: np.ndarray,
    ray_hit: np.ndarray,
    tr: TrackArrays,
    kp: np.ndarray,
    rp: np.ndarray,
    ray_bins: np.ndarray,
    ray_cos: np.ndarray,
    ray_sin: np.ndarray,
    scratch_bodies: np.ndarray,
    scratch_fan: np.ndarray,
    scratch_centre: np.ndarray,
) -> None:
    """The range rays of every kart in race ``b`` (at angles from the heading whose cos and sin are given,
    and which times ``tr.ray_bins / (2 pi)`` are ``ray_bins``): distance to the first wall or kart, and what
    it hit. ``scratch_bodies`` holds the karts' bodies (see :func:`_bodies`) and ``scratch_centre`` their
    located [sample index, lateral offset]; ``scratch_fan`` is (3, rays).

    A sensor origin clearly between the walls (by the kart's lateral offset) tests each
    ray against its cell's list for the ray's direction bin; any other origin tests the cell's whole reach
    list, as :func:`ray_fan_walls` does. Both give the distance to the first wall.
    """
    K = F.shape[1]
    hl = kp[P_HALF_LENGTH]
    r = kp[P_RADIUS]
    max_range = rp[RP_RAY_RANGE]
    origin = rp[RP_RAY_ORIGIN]
    n_rays = ray_cos.shape[0]
    walls = tr.wall_segments
    index = tr.ray_bin_index
    start = tr.ray_bin_start
    bins = tr.ray_bins
    bin_scale = bins / (2.0 * math.pi)
    inside = abs(origin) + ORIGIN_TRACK_MARGIN
    body = scratch_bodies
    dxs = scratch_fan[0]
    dys = scratch_fan[1]
    wall = scratch_fan[2]
    for k in range(K):
        ch, sh = body[k, 0], body[k, 1]
        ox = F[b, k, F_X] + origin * ch
        oy = F[b, k, F_Y] + origin * sh
        for a in range(n_rays):
            dxs[a] = ch * ray_cos[a] - sh * ray_sin[a]
            dys[a] = sh * ray_cos[a] + ch * ray_sin[a]
        cell = ray_cell(tr, ox, oy)
        idx, d = int(scratch_centre[k, 0]), scratch_centre[k, 1]
        if cell >= 0 and d + inside < tr.near_width_left[idx] and inside - d < tr.near_width_right[idx]:
            # on the track: one short list per ray
            heading_bin = (F[b, k, F_HEADING] + math.pi) * bin_scale
            base = cell * bins
            for a in range(n_rays):
                slot = base + ray_bin_scaled(heading_bin + ray_bins[a], bins)
                wall[a] = ray_first_wall(walls, index, start[slot], start[slot + 1], ox, oy, dxs[a], dys[a], max_range)
        else:
            ray_fan_walls(tr, ox, oy, dxs, dys, max_range, wall)
        for a in range(n_rays):
            dx, dy = dxs[a], dys[a]
            dist = wall[a]
            kind = HIT_WALL if dist < max_range else HIT_NONE
            for j in range(K):
                if j == k or I[b, j, I_FINISHED]:
                    continue
                rel_x, rel_y = F[b, j, F_X] - ox, F[b, j, F_Y] - oy
                along = rel_x * dx + rel_y * dy
                if along < -(hl + r) or along > dist + hl + r or abs(rel_x * dy - rel_y * dx) > hl + r:
                    continue
                t = ray_capsule(ox, oy, dx, dy, body[j, 2], body[j, 3], body[j, 4], body[j, 5], r)
                if t < dist:
                    dist, kind = t, HIT_KART
            ray_dist[b, k, a] = dist
            ray_hit[b, k, a] = kind


@njit(cache=True)
def step_batch(
    F: np.ndarray,
    I: np.ndarray,
    R: np.ndarray,
    pair_flags: np.ndarray,
    target_lane: np.ndarray,
    target_speed: np.ndarray,
    ray_dist: np.ndarray,
    ray_hit: np.ndarray,
    actions: np.ndarray,
    tr: TrackArrays,
    kp: np.ndarray,
    rp: np.ndarray,
    ray_angles: np.ndarray,
    sensors_on: bool,
    n_steps: int,
) -> None:
    """Advance every race of the batch by ``n_steps`` steps with the same actions held."""
    K = F.shape[1]
    ray_cos = np.cos(ray_angles)
    ray_sin = np.sin(ray_angles)
    ray_bins = (ray_angles + math.pi) % (2.0 * math.pi) - math.pi  # the bin offsets of the ray angles
    ray_bins *= tr.ray_bins / (2.0 * math.pi)
    scratch_f = np.empty((4, K))
    scratch_b = np.zeros((2, K), dtype=np.bool_)
    scratch_pairs = np.zeros((K, K), dtype=np.bool_)
    scratch_bodies = np.empty((K, 6))
    scratch_located = np.full((K, 5), np.nan)
    scratch_fan = np.empty((3, ray_angles.shape[0]))
    scratch_centre = np.empty((K, 2))
    scratch_touch = np.zeros((2, K, K), dtype=np.bool_)
    for _ in range(n_steps):
        for b in range(F.shape[0]):
            step_race(
                b,
                F,
                I,
                R,
                pair_flags,
                target_lane,
                target_speed,
                ray_dist,
                ray_hit,
                actions,
                tr,
                kp,
                rp,
                ray_bins,
                ray_cos,
                ray_sin,
                sensors_on,
                scratch_f,
                scratch_b,
                scratch_pairs,
                scratch_bodies,
                scratch_located,
                scratch_fan,
                scratch_centre,
                scratch_touch,
            )


@njit(cache=True)
def sense_batch(
    F: np.ndarray,
    I: np.ndarray,
    ray_dist: np.ndarray,
    ray_hit: np.ndarray,
    tr: TrackArrays,
    kp: np.ndarray,
    rp: np.ndarray,
    ray_angles: np.ndarray,
) -> None:
    """Cast every kart's rays (used after a reset, before the first step)."""
    ray_cos = np.cos(ray_angles)
    ray_sin = np.sin(ray_angles)
    ray_bins = (ray_angles + math.pi) % (2.0 * math.pi) - math.pi  # the bin offsets of the ray angles
    ray_bins *= tr.ray_bins / (2.0 * math.pi)
    scratch_bodies = np.empty((F.shape[1], 6))
    scratch_fan = np.empty((3, ray_angles.shape[0]))
    scratch_centre = np.empty((F.shape[1], 2))
    for b in range(F.shape[0]):
        for k in range(F.shape[1]):
            idx, _s, d = locate(tr, F[b, k, F_X], F[b, k, F_Y], I[b, k, I_CENTRE_IDX])
            scratch_centre[k, 0] = idx
            scratch_centre[k, 1] = d
        _bodies(b, F, kp[P_HALF_LENGTH], scratch_bodies)
        cast_rays(
            b,
            F,
            I,
            ray_dist,
            ray_hit,
            tr,
            kp,
            rp,
            ray_bins,
            ray_cos,
            ray_sin,
            scratch_bodies,
            scratch_fan,
            scratch_centre,
        )
